// gonioctl scan watch: follows a scan through its notifications (see ctl_internal.hpp).
#include <unistd.h>

#include <iostream>

#include <fmt/format.h>

#include "ctl/ctl_internal.hpp"
#include "gonio/daemon/ctl/ctl.hpp"

namespace gonio::daemon::ctl {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

int watch_scan(Session& s, std::int64_t scan, bool json_lines, bool exit_status) {
  auto& c = s.client();
  c.call("subscribe", json{{"topics", {"progress", "points", "alerts", "state"}}, {"scan", scan}});
  json sc = c.call("scan.get", json{{"scan", scan}});
  std::size_t done = sc["points_done"].get<std::size_t>(), total = sc["points_total"].get<std::size_t>();
  // The alerts standing when the watch begins (a finished scan has its own), then the new ones.
  std::size_t diverged = sc["points_diverged"].get<std::size_t>(), alerts = scan_alerts(s, scan).standing;
  std::string state = sc["state"].get<std::string>(), reason = sc["reason"].get<std::string>();
  double eta = -1;
  const bool tty = ::isatty(STDOUT_FILENO) != 0;
  int last_decile = -1;
  const auto terminal = [](const std::string& st) {
    return st == "completed" || st == "failed" || st == "cancelled" || st == "paused";
  };
  const auto draw = [&] {
    if (json_lines) return;
    const auto line = fmt::format("scan {} {:<9} {}  alerts {}", scan, state,
                                  progress_bar(done, total, eta, diverged), alerts);
    if (tty) {
      std::cout << "\r" << line << "\033[K" << std::flush;
    } else {
      const int decile = total ? static_cast<int>(10 * done / total) : 10;
      if (decile != last_decile || terminal(state)) {
        last_decile = decile;
        std::cout << line << "\n" << std::flush;
      }
    }
  };
  draw();
  auto last_poll = Clock::now();
  while (!terminal(state)) {
    const auto n = c.next_notification(std::chrono::milliseconds(1000));
    if (n) {
      if (json_lines) std::cout << n->dump() << "\n" << std::flush;
      const auto method = n->value("method", "");
      const auto& p = (*n)["params"];
      if (method == "scan.progress" && p.value("scan", std::int64_t{0}) == scan) {
        done = p["points_done"].get<std::size_t>();
        total = p["points_total"].get<std::size_t>();
        diverged = p["points_diverged"].get<std::size_t>();
        eta = p["eta_s"].get<double>();
        state = p["state"].get<std::string>();
        reason = p.value("reason", "");
      } else if (method == "scan.state" && p.value("scan", std::int64_t{0}) == scan) {
        state = p["state"].get<std::string>();
        reason = p.value("reason", "");
      } else if (method == "alert" && p.value("scan_id", scan) == scan) {
        if (p.value("count", 1) == 1) ++alerts;
      }
      draw();
    }
    // Notifications may be dropped under load: the store has the truth.
    if (Clock::now() - last_poll > std::chrono::seconds(5) || terminal(state)) {
      last_poll = Clock::now();
      sc = c.call("scan.get", json{{"scan", scan}});
      done = sc["points_done"].get<std::size_t>();
      diverged = sc["points_diverged"].get<std::size_t>();
      state = sc["state"].get<std::string>();
      reason = sc["reason"].get<std::string>();
      draw();
    }
  }
  // The store's final word: the verdict and the alerts as they stand now (a sustained alert's
  // message follows the verdict; the ones the verdict no longer supports are resolved).
  sc = c.call("scan.get", json{{"scan", scan}});
  if (!json_lines) {
    if (tty) std::cout << "\n";
    const auto a = scan_alerts(s, scan);
    for (const auto& x : a.list)
      if (x.value("resolved_at", json()).is_null())
        std::cout << fmt::format("alert {} [{}] {}\n", cell(x["id"]), cell(x["severity"]), cell(x["message"]));
    std::cout << fmt::format("scan {} {}{}: {} of {} points, {} diverged\n", scan, state,
                             reason.empty() ? "" : " (" + reason + ")", done, total, diverged)
              << verdict_text(sc["verdict"]) << alerts_text(a, scan);
  } else {
    std::cout << sc.dump() << "\n";
  }
  if (state != "completed") return ctl_exit::scan_not_completed;
  return exit_status ? verdict_exit_code(sc) : ctl_exit::ok;
}

}  // namespace gonio::daemon::ctl
