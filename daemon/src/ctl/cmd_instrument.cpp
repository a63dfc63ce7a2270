// gonioctl instrument: status and manual control (home, move, stop, reset).
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "ctl/ctl_internal.hpp"
#include "gonio/daemon/ctl.hpp"

namespace gonio::daemon::ctl {

using nlohmann::json;

namespace {

struct InstrumentArgs {
  std::vector<std::string> home_axes;
  std::map<std::string, double> move_targets;
};

}  // namespace

void add_instrument_commands(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<InstrumentArgs>();
  auto* inst = app.add_subcommand("instrument", "instrument status and manual control");
  inst->require_subcommand(1);
  inst->add_subcommand("status", "arm positions, state, drivers")->callback([&ctx] {
    ctx.action = [](Session& s) {
      const auto r = s.call("instrument.status");
      print(s.options(), r, [&] { print_fields(r); });
      return 0;
    };
  });
  auto* home = inst->add_subcommand("home", "home axes (all when none named)");
  home->add_option("axes", args->home_axes, "incidence, receive, rotation, tilt");
  home->callback([&ctx, args] {
    ctx.action = [args](Session& s) {
      json p = json::object();
      if (!args->home_axes.empty()) p["axes"] = args->home_axes;
      const auto r = s.call("instrument.home", p);
      print(s.options(), r, [&] { print_fields(r["positions"], "position"); });
      return 0;
    };
  });
  auto* mv = inst->add_subcommand("move", "move arms: --incidence 45 --receive 30");
  for (const char* axis : {"incidence", "receive", "rotation", "tilt"})
    mv->add_option_function<double>(std::string("--") + axis, [args, axis](double v) { args->move_targets[axis] = v; },
                                    std::string(axis) + " angle in degrees");
  mv->callback([&ctx, args] {
    ctx.action = [args](Session& s) {
      json p = json::object();
      for (const auto& [k, v] : args->move_targets) p[k] = v;
      const auto r = s.call("instrument.move", p);
      print(s.options(), r, [&] { print_fields(r["positions"], "position"); });
      return 0;
    };
  });
  inst->add_subcommand("stop", "stop every axis now (pauses the running scan)")->callback([&ctx] {
    ctx.action = [](Session& s) {
      const auto r = s.call("instrument.stop");
      print(s.options(), r, [&] { std::cout << "stopped" << (r["scan"].is_null() ? "" : fmt::format("; scan {} pauses", cell(r["scan"]))) << "\n"; });
      return 0;
    };
  });
  inst->add_subcommand("reset", "clear alarms and the fault latch")->callback([&ctx] {
    ctx.action = [](Session& s) {
      const auto r = s.call("instrument.reset");
      print(s.options(), r, [&] { std::cout << "state: " << cell(r["state"]) << "\n"; });
      return 0;
    };
  });
}

}  // namespace gonio::daemon::ctl
