// gonioctl queue: the running and waiting scans, and moving a waiting one.
#include <cstdint>
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "ctl/ctl_internal.hpp"
#include "gonio/daemon/ctl/ctl.hpp"

namespace gonio::daemon::ctl {

using nlohmann::json;

namespace {

struct QueueArgs {
  std::int64_t scan = 0;
  std::size_t position = 0;
};

}  // namespace

void add_queue_commands(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<QueueArgs>();
  auto* queue = app.add_subcommand("queue", "the scan queue");
  queue->require_subcommand(1);
  queue->add_subcommand("status", "running and waiting scans")->callback([&ctx] {
    ctx.action = [](Session& s) {
      const auto r = s.call("queue.status");
      print(s.options(), r, [&] {
        std::cout << "instrument: " << cell(r["instrument"]) << "\n";
        std::cout << "running: " << (r["running"].is_null() ? "-" : cell(r["running"]["id"])) << "\n";
        json all = json::array();
        if (!r["running"].is_null()) all.push_back(r["running"]);
        for (const auto& w : r["waiting"]) all.push_back(w);
        scans_table(all, sample_names(s));
      });
      return 0;
    };
  });
  auto* reorder = queue->add_subcommand("reorder", "move a waiting scan to a position (0 = next)");
  reorder->add_option("scan", args->scan)->required();
  reorder->add_option("position", args->position)->required();
  reorder->callback([&ctx, args] {
    ctx.action = [args](Session& s) {
      const auto r = s.call("queue.reorder", json{{"scan", args->scan}, {"position", args->position}});
      print(s.options(), r, [&] { scans_table(r["waiting"], sample_names(s)); });
      return 0;
    };
  });
}

}  // namespace gonio::daemon::ctl
