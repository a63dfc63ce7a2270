// gonioctl alert: listing and acknowledging alerts.
#include <cstdint>
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "ctl/ctl_internal.hpp"
#include "gonio/daemon/ctl/ctl.hpp"

namespace gonio::daemon::ctl {

using nlohmann::json;

namespace {

void alerts_table(const json& list) {
  Table t({"id", "severity", "kind", "scan", "count", "ack", "last", "message"});
  for (const auto& a : list)
    t.add({cell(a["id"]), cell(a["severity"]), cell(a["kind"]), cell(a["scan_id"]), cell(a["count"]),
           a["acknowledged"].get<bool>() ? cell(a["acknowledged_by"]) : "-", cell(a["last_at"]),
           cell(a["message"])});
  std::cout << t.render();
}

struct AlertArgs {
  bool all = false;
  std::int64_t scan = 0, id = 0;
};

}  // namespace

void add_alert_commands(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<AlertArgs>();
  auto* alert = app.add_subcommand("alert", "divergence and instrument alerts");
  alert->require_subcommand(1);
  auto* alist = alert->add_subcommand("list", "open alerts (--all: also acknowledged ones)");
  alist->add_flag("--all", args->all);
  alist->add_option("--scan", args->scan);
  alist->callback([&ctx, args] {
    ctx.action = [args](Session& s) {
      json p{{"limit", 1000}};
      if (!args->all) p["acknowledged"] = false;
      if (args->scan) p["scan"] = args->scan;
      const auto r = s.call("alert.list", p);
      print(s.options(), r, [&] { alerts_table(r); });
      return 0;
    };
  });
  auto* ack = alert->add_subcommand("ack", "acknowledge an alert");
  ack->add_option("alert", args->id)->required();
  ack->callback([&ctx, args] {
    ctx.action = [args](Session& s) {
      const auto r = s.call("alert.ack", json{{"alert", args->id}});
      print(s.options(), r, [&] { alerts_table(json::array({r})); });
      return 0;
    };
  });
}

}  // namespace gonio::daemon::ctl
