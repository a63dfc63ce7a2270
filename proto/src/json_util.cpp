#include "gonio/proto/json_util.hpp"

#include <fmt/format.h>

namespace gonio::json_util {

Error prefixed(const Error& e, std::string_view prefix) {
  const std::string field = join_field(prefix, e.field());
  std::string message = e.what();
  // Messages open with their field name; keep them reading naturally.
  if (!e.field().empty() && message.rfind(e.field(), 0) == 0)
    message = field + message.substr(e.field().size());
  else
    message = fmt::format("{}: {}", prefix, message);
  return Error(e.code(), std::move(message), field);
}

std::string type_name(const nlohmann::json& j) { return j.type_name(); }

ObjectReader::ObjectReader(const nlohmann::json& j, std::string context)
    : j_(j), context_(std::move(context)) {
  if (!j_.is_object())
    throw Error::invalid(context_.empty() ? "params" : context_,
                         "expected an object, got " + type_name(j_));
}

const nlohmann::json* ObjectReader::raw(const std::string& key) {
  used_.insert(key);
  const auto it = j_.find(key);
  return it == j_.end() ? nullptr : &*it;
}

void ObjectReader::finish() const {
  for (const auto& [key, value] : j_.items()) {
    (void)value;
    if (!used_.contains(key)) {
      std::string allowed;
      for (const auto& k : used_) allowed += (allowed.empty() ? "" : ", ") + k;
      throw Error::invalid(path(key), fmt::format("unknown key (allowed: {})", allowed));
    }
  }
}

}  // namespace gonio::json_util
