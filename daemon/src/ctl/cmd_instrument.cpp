// gonioctl instrument: status, manual control (home, move, stop, reset) and calibrate.
#include <algorithm>
#include <cstdint>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "ctl/ctl_internal.hpp"
#include "gonio/daemon/ctl/ctl.hpp"

namespace gonio::daemon::ctl {

using nlohmann::json;

namespace {

struct InstrumentArgs {
  std::vector<std::string> home_axes;
  std::map<std::string, double> move_targets;
  std::int64_t scan = 0;
  std::string fit, sample;
  std::uint64_t samples = 0;
  bool dry_run = false;
};

// "receive_offset_deg,gain" -> ["receive_offset_deg", "gain"]
json split_list(const std::string& text) {
  json out = json::array();
  std::size_t start = 0;
  while (start <= text.size()) {
    const auto end = std::min(text.find(',', start), text.size());
    if (end > start) out.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  return out;
}

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
  auto* cal = inst->add_subcommand(
      "calibrate", "fit instrument parameters to a scan of a known sample; store the corrected profile");
  cal->add_option("scan", args->scan, "id of the calibration scan")->required();
  cal->add_option("--fit", args->fit,
                  "parameters, comma-separated: incidence_offset_deg, receive_offset_deg, "
                  "sample_tilt_deg, source_aperture_scale, receiver_aperture_scale, gain")
      ->required();
  cal->add_option("--sample", args->sample, "the known sample's BSDF spec (default: the scan's sample)");
  cal->add_option("--samples", args->samples, "twin paths per geometry and evaluation (default 8192)");
  cal->add_flag("--dry-run", args->dry_run, "fit and store the result, keep the current profile");
  cal->callback([&ctx, args] {
    ctx.action = [args](Session& s) {
      json p{{"scan", args->scan}, {"fit", split_list(args->fit)}};
      if (!args->sample.empty()) p["sample"] = args->sample;
      if (args->samples) p["samples"] = args->samples;
      if (args->dry_run) p["dry_run"] = true;
      const auto r = s.call("instrument.calibrate", p);
      print(s.options(), r, [&] {
        fit_human(r);
        const auto& prof = r["profile"];
        if (r.value("applied", false))
          std::cout << fmt::format("profile {} version {} in use from now on\n", cell(prof["name"]),
                                   cell(prof["version"]));
        else
          std::cout << fmt::format("not applied: {}; profile {} version {} stays in use\n",
                                   cell(r["reason"]), cell(prof["name"]), cell(prof["version"]));
      });
      return 0;
    };
  });
}

}  // namespace gonio::daemon::ctl
