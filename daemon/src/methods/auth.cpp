// rpc.discover and the auth.* methods: the OpenRPC document, logging in, tokens.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "methods/params.hpp"
#include "methods/registrar.hpp"

namespace gonio::daemon {

using json_util::ObjectReader;
using methods::actor;
using methods::principal_json;
using nlohmann::json;

void register_auth(MethodRegistrar& reg, Services& s) {
  // One serialised copy, shared by every caller: a batch of discovers costs no document
  // tree per call (and the batch and response limits bound the rest).
  static const auto discover = std::make_shared<const std::string>(openrpc_document().dump());
  reg.add("rpc.discover", [](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    return rpc::RawJson{{}, discover};
  });

  reg.add("auth.login", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto token = r.required<std::string>("token");
    r.finish();
    auto p = s.auth.authenticate(token, c.session->transport());
    if (!p) {
      spdlog::warn("auth.login refused on {} from {}", c.session->transport(), c.session->peer());
      throw Error(Errc::unauthorized, "token: unknown token", "token");
    }
    c.session->set_principal(*p);
    spdlog::info("{} logged in as {} on {} from {}", p->name, to_text(p->role),
                 c.session->transport(), c.session->peer());
    return principal_json(*p);
  });

  reg.add("auth.whoami", [](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    return principal_json(c.principal);
  });

  reg.add("auth.create_token", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto name = r.required<std::string>("name");
    const auto role = parse_role(r.required<std::string>("role"), "role");
    r.finish();
    if (name.empty() || name.size() > 64 || name.find_first_of(" \t\n:") != std::string::npos)
      throw Error::invalid("name", "must have 1 to 64 characters, without spaces or ':'");
    const auto token = s.auth.create(name, role);
    s.store.audit(actor(c), "auth.create_token", fmt::format("token:{}", name),
                  json{{"role", to_text(role)}});
    return json{{"name", name}, {"role", to_text(role)}, {"token", token}};
  });

  reg.add("auth.list_tokens", [&s](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    json out = json::array();
    for (const auto& t : s.auth.list()) out.push_back(json{{"name", t.name}, {"role", to_text(t.role)}});
    return out;
  });

  reg.add("auth.revoke_token", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto name = r.required<std::string>("name");
    r.finish();
    if (!s.auth.revoke(name)) throw Error::not_found("name", fmt::format("token '{}'", name));
    s.store.audit(actor(c), "auth.revoke_token", fmt::format("token:{}", name));
    // Sessions logged in with it end now (HTTP requests are checked one by one anyway).
    if (s.end_sessions_of) s.end_sessions_of(name);
    return json{{"revoked", name}};
  });
}

}  // namespace gonio::daemon
