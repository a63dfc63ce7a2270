// gonioctl info, discover and call: the daemon itself and any method by name.
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "ctl/ctl_internal.hpp"
#include "gonio/daemon/ctl/ctl.hpp"
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

std::string links(const json& devices) {
  std::string out;
  for (const char* side : {"motion", "photometer"}) {
    if (!devices.contains(side)) continue;
    const auto& d = devices[side];
    out += fmt::format("{}{} {} {}", out.empty() ? "" : ", ", side, cell(d.value("driver", json())),
                       cell(d.value("link", json())));
  }
  return out;
}

// The instrument first (what a technician asks), the daemon's counters only with --verbose.
void info_human(const json& info, const json& status, const json& queue, bool verbose) {
  std::cout << fmt::format("goniod {} (API {}), up {}, state dir {}; you are {} ({})\n", cell(info["version"]),
                           cell(info["api_version"]), format_duration(info["uptime_s"].get<double>()),
                           cell(info["state_dir"]), cell(info["you"]["name"]), cell(info["you"]["role"]));
  const bool available = status.value("available", false);
  const bool latched = status.value("fault_latched", false);
  std::cout << fmt::format("instrument: {}, {}{}\n", cell(status["state"]),
                           available ? "connected" : "not connected",
                           status.contains("devices") ? " (" + links(status["devices"]) + ")" : "");
  std::cout << (latched ? fmt::format("  fault latched: {} (gonioctl instrument reset once it is safe)\n",
                                      cell(status["fault_reason"]))
                        : std::string("  fault latch: clear\n"));
  if (const auto error = status.value("error", std::string()); !error.empty()) std::cout << "  error: " << error << "\n";
  const auto& running = info["running_scan"];
  std::cout << fmt::format("  scan: {}; {} waiting\n",
                           running.is_null() ? std::string("none running") : "scan " + cell(running) + " running",
                           queue.contains("waiting") ? queue["waiting"].size() : 0);
  if (status.contains("profile"))
    std::cout << fmt::format("  profile {} version {}; twin {}\n", cell(status["profile"]["name"]),
                             cell(status["profile"]["version"]), cell(info["twin"]["version"]));
  if (status.contains("storage")) {
    const auto& st = status["storage"];
    std::cout << fmt::format("  storage: {}, {:.0f} MB free{}\n", st.value("writable", false) ? "writable" : "NOT writable",
                             st.value("free_mb", 0.0), st.value("low", false) ? " (low)" : "");
  }
  if (!verbose) {
    std::cout << "(counters: gonioctl info --verbose)\n";
    return;
  }
  std::cout << "\n";
  print_fields(info);
  std::cout << "\n";
  print_fields(status, "instrument");
}

}  // namespace

void add_system_commands(CLI::App& app, Context& ctx) {
  auto verbose = std::make_shared<bool>(false);
  auto* info = app.add_subcommand("info", "the instrument's state, then the daemon (system.info)");
  info->add_flag("--verbose,-v", *verbose, "every counter of system.info and instrument.status");
  info->callback([&ctx, verbose] {
    ctx.action = [verbose](Session& s) {
      const auto r = s.call("system.info");
      print(s.options(), r, [&] {
        info_human(r, s.call("instrument.status"), s.call("queue.status"), *verbose);
      });
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
