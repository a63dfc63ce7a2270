// gonioctl alert: listing and acknowledging alerts.
#include <cstdint>
#include <iostream>
#include <memory>
#include <string>

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

// Standing alerts first; the ones goniod resolved apart, each with its resolution.
void alerts_tables(const json& list) {
  json standing = json::array(), resolved = json::array();
  for (const auto& a : list) (a.value("resolved_at", json()).is_null() ? standing : resolved).push_back(a);
  if (!standing.empty() || resolved.empty()) alerts_table(standing);
  if (resolved.empty()) return;
  std::cout << (standing.empty() ? "" : "\n") << "resolved:\n";
  Table t({"id", "severity", "kind", "scan", "resolved", "resolution"});
  for (const auto& a : resolved)
    t.add({cell(a["id"]), cell(a["severity"]), cell(a["kind"]), cell(a["scan_id"]), cell(a["resolved_at"]),
           cell(a["resolution"])});
  std::cout << t.render();
}

struct AlertArgs {
  bool all = false;
  std::int64_t scan = 0, id = 0;
  std::string state;
};

}  // namespace

void add_alert_commands(CLI::App& app, Context& ctx) {
  auto args = std::make_shared<AlertArgs>();
  auto* alert = app.add_subcommand("alert", "divergence and instrument alerts");
  alert->require_subcommand(1);
  auto* alist = alert->add_subcommand(
      "list", "unacknowledged alerts, those goniod resolved apart (--all: also acknowledged ones)");
  alist->add_flag("--all", args->all);
  alist->add_option("--scan", args->scan);
  alist->add_option("--state", args->state, "standing, resolved or all (default: all)");
  alist->callback([&ctx, args] {
    ctx.action = [args](Session& s) {
      json p{{"limit", 1000}};
      if (!args->all) p["acknowledged"] = false;
      if (args->scan) p["scan"] = args->scan;
      if (!args->state.empty()) p["state"] = args->state;
      const auto r = s.call("alert.list", p);
      print(s.options(), r, [&] { alerts_tables(r); });
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
