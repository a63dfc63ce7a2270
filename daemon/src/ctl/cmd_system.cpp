// gonioctl info, discover and call: the daemon itself and any method by name.
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "ctl/ctl_internal.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon::ctl {

using nlohmann::json;

namespace {

json parse_json_arg(const std::string& text, const std::string& what) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded()) throw Error::invalid(what, fmt::format("'{}' is not JSON", text));
  return j;
}

struct CallArgs {
  std::string method, params = "{}";
};

}  // namespace

void add_system_commands(CLI::App& app, Context& ctx) {
  auto* info = app.add_subcommand("info", "daemon information (system.info)");
  info->callback([&ctx] {
    ctx.action = [](Session& s) {
      const auto r = s.call("system.info");
      print(s.options(), r, [&] { print_fields(r); });
      return 0;
    };
  });
  auto* discover = app.add_subcommand("discover", "the OpenRPC document (rpc.discover)");
  discover->callback([&ctx] {
    ctx.action = [](Session& s) {
      std::cout << s.call("rpc.discover").dump(2) << "\n";
      return 0;
    };
  });
  auto args = std::make_shared<CallArgs>();
  auto* call = app.add_subcommand("call", "call any method: gonioctl call METHOD '{\"k\": v}'");
  call->add_option("method", args->method)->required();
  call->add_option("params", args->params, "params as a JSON object");
  call->callback([&ctx, args] {
    ctx.action = [args](Session& s) {
      std::cout << s.call(args->method, parse_json_arg(args->params, "params")).dump(2) << "\n";
      return 0;
    };
  });
}

}  // namespace gonio::daemon::ctl
