// MethodRegistrar: handlers attached to the method table by name.
#include "methods/registrar.hpp"

#include <fmt/format.h>

#include "gonio/daemon/methods/method_table.hpp"

namespace gonio::daemon {

void MethodRegistrar::add(std::string_view name, rpc::Handler handler) {
  const auto* spec = find_method_spec(name);
  if (!spec)
    throw Error(Errc::internal, fmt::format("method '{}' has a handler but no entry in the method table", name));
  if (!added_.emplace(name).second)
    throw Error(Errc::internal, fmt::format("method '{}' has two handlers", name));
  d_.add(rpc::Method{std::string(spec->name), spec->role, spec->blocking, std::move(handler), spec->control});
}

void MethodRegistrar::finish() const {
  std::string missing;
  for (const auto& m : kMethodTable)
    if (!added_.contains(m.name)) missing += fmt::format("{}{}", missing.empty() ? "" : ", ", m.name);
  if (!missing.empty())
    throw Error(Errc::internal, fmt::format("methods in the method table without a handler: {}", missing));
}

}  // namespace gonio::daemon
