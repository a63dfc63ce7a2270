// Shared parameter readers and lookups of the method families.
#include "methods/params.hpp"

#include <optional>

#include <fmt/format.h>

namespace gonio::daemon::methods {

using json_util::ObjectReader;
using nlohmann::json;

std::int64_t read_id(ObjectReader& r, const std::string& key) {
  const auto v = r.required<std::int64_t>(key);
  if (v <= 0) throw Error::invalid(r.path(key), fmt::format("{} is not an id (ids are >= 1)", v));
  return v;
}

std::size_t read_count(ObjectReader& r, const std::string& key, std::size_t fallback,
                       std::size_t max) {
  return static_cast<std::size_t>(r.optional_in<long long>(key, static_cast<long long>(fallback), 0,
                                                           static_cast<long long>(max)));
}

std::size_t read_offset(ObjectReader& r) {
  return read_count(r, "offset", 0, static_cast<std::size_t>(1) << 40);
}

Sample resolve_sample(const Store& store, const json& ref, const std::string& field) {
  std::optional<Sample> s;
  if (ref.is_number_integer()) {
    const auto id = ref.get<std::int64_t>();
    s = store.sample(id);
    if (!s) throw Error::not_found(field, fmt::format("sample {}", id));
  } else if (ref.is_string()) {
    const auto name = ref.get<std::string>();
    s = store.sample_by_name(name);
    if (!s) throw Error::not_found(field, fmt::format("sample '{}'", name));
  } else {
    throw Error::invalid(field, "expected a sample id or name, got " + json_util::type_name(ref));
  }
  return *s;
}

Scan require_scan(const Store& store, std::int64_t id) {
  auto s = store.scan(id);
  if (!s) throw Error::not_found("scan", fmt::format("scan {}", id));
  return *s;
}

std::string actor(const rpc::Call& c) { return c.principal.name; }

json principal_json(const Principal& p) {
  return json{{"name", p.name}, {"role", to_text(p.role)}, {"transport", p.transport}};
}

json scan_summary(const Scan& s) { return to_json(s, false); }

}  // namespace gonio::daemon::methods
