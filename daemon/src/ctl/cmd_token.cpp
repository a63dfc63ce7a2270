// gonioctl token: hashing a token for the config (local), creating, listing and revoking
// stored tokens (auth.*).
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "ctl/ctl_internal.hpp"
#include "gonio/daemon/ctl/ctl.hpp"
#include "gonio/daemon/rpc/auth.hpp"

namespace gonio::daemon::ctl {

using nlohmann::json;

namespace {

struct TokenArgs {
  std::string text, name, role;
};

}  // namespace

void add_token_commands(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<TokenArgs>();
  auto* token = app.add_subcommand("token", "bearer tokens");
  token->require_subcommand(1);
  auto* hash = token->add_subcommand("hash", "SHA-256 of a token, for [[auth.token]] in the config");
  hash->add_option("token", args->text)->required();
  hash->callback([&ctx, args] {
    ctx.action = [args](Session&) {
      std::cout << sha256_hex(args->text) << "\n";
      return 0;
    };
  });
  auto* tcreate = token->add_subcommand("create", "create a token (admin); prints it once");
  tcreate->add_option("name", args->name)->required();
  tcreate->add_option("role", args->role)->required()->check(CLI::IsMember({"viewer", "technician", "admin"}));
  tcreate->callback([&ctx, args] {
    ctx.action = [args](Session& s) {
      const auto r = s.call("auth.create_token", json{{"name", args->name}, {"role", args->role}});
      print(s.options(), r, [&] { std::cout << r["token"].get<std::string>() << "\n"; });
      return 0;
    };
  });
  token->add_subcommand("list", "token names and roles (admin)")->callback([&ctx] {
    ctx.action = [](Session& s) {
      const auto r = s.call("auth.list_tokens");
      print(s.options(), r, [&] {
        Table t({"name", "role"});
        for (const auto& x : r) t.add({cell(x["name"]), cell(x["role"])});
        std::cout << t.render();
      });
      return 0;
    };
  });
  auto* trevoke = token->add_subcommand("revoke", "revoke a stored token (admin)");
  trevoke->add_option("name", args->name)->required();
  trevoke->callback([&ctx, args] {
    ctx.action = [args](Session& s) {
      const auto r = s.call("auth.revoke_token", json{{"name", args->name}});
      print(s.options(), r, [&] { std::cout << "revoked " << args->name << "\n"; });
      return 0;
    };
  });
}

}  // namespace gonio::daemon::ctl
