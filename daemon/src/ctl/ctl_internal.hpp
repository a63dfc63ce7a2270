// Shared pieces of gonioctl's commands (not a public header).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "gonio/daemon/ctl/client.hpp"

namespace CLI {
class App;
}

namespace gonio::daemon::ctl {

struct Options {
  std::string state_dir;
  std::string connect;  // unix:PATH, tcp://, tls:// or https://HOST:PORT; default unix:<state-dir>/goniod.sock
  std::string token, token_file;
  std::string ca;  // tls://, https://: the CA file the server's certificate must chain to (else the system's)
  bool json = false;
  double timeout_s = 120;
};

// Connects on first use; logs in with the token when the transport needs it.
class Session {
 public:
  explicit Session(Options o) : o_(std::move(o)) {}
  Client& client();
  nlohmann::json call(const std::string& method, const nlohmann::json& params = nlohmann::json::object()) {
    return client().call(method, params);
  }
  const Options& options() const noexcept { return o_; }

 private:
  Options o_;
  std::optional<Client> client_;
};

std::string default_state_dir();

// What the command groups share while the command line is parsed: the callback of the
// chosen subcommand sets `action`, which gonioctl_main then runs with a Session that
// connects on first use (so local commands such as `token hash` never connect).
struct Context {
  std::function<int(Session&)> action;
};

// One per command group, each in its own file (ctl/cmd_<group>.cpp), in the order of
// gonioctl's help.
void add_system_commands(CLI::App& app, Context& ctx);      // info, discover, call
void add_instrument_commands(CLI::App& app, Context& ctx);  // instrument ...
void add_sample_commands(CLI::App& app, Context& ctx);      // sample ...
void add_scan_commands(CLI::App& app, Context& ctx);        // scan ...
void add_queue_commands(CLI::App& app, Context& ctx);       // queue ...
void add_alert_commands(CLI::App& app, Context& ctx);       // alert ...
void add_archive_commands(CLI::App& app, Context& ctx);     // archive ...
void add_backup_commands(CLI::App& app, Context& ctx);      // backup FILE
void add_twin_commands(CLI::App& app, Context& ctx);        // twin ...
void add_token_commands(CLI::App& app, Context& ctx);       // token ...
void add_demo_commands(CLI::App& app, Context& ctx);        // demo

// A sample given on the command line: all digits is an id, anything else a name.
nlohmann::json sample_ref(const std::string& text);
// Every sample's name by id (sample.list), for tables that show samples.
std::map<std::int64_t, std::string> sample_names(Session& s);
// The table of scans that `scan list` and `queue status` print, samples by name.
void scans_table(const nlohmann::json& list, const std::map<std::int64_t, std::string>& names = {});
// A stored fit (scan.fit, instrument.calibrate): parameters, χ², naive fit, warnings.
void fit_human(const nlohmann::json& fit);

// Prints a result: JSON (pretty) with --json, else `human`.
void print(const Options& o, const nlohmann::json& result, const std::function<void()>& human);
// key: value lines of an object (nested objects flattened with dots).
void print_fields(const nlohmann::json& obj, const std::string& prefix = {});

// The verdict's lines: decision and points, the named cause with its value and what the
// catalogue or data sheet says (or "unexplained" and the worst regions), the summary.
std::string verdict_text(const nlohmann::json& verdict);
// A scan's alerts (alert.list), counted: standing (of them critical) and resolved.
struct ScanAlerts {
  std::size_t standing = 0, critical = 0, resolved = 0;
  nlohmann::json list;
};
ScanAlerts scan_alerts(Session& s, std::int64_t scan);
std::string alerts_text(const ScanAlerts& a, std::int64_t scan);
// --exit-status: ctl_exit::out_of_tolerance or instrument_out_of_spec by the verdict of a
// scan.get result, else 0.
int verdict_exit_code(const nlohmann::json& scan);

// Follows a scan until it completes, fails, is cancelled or paused, then prints its
// verdict and alerts. Returns the exit code: 9 when it ended other than completed; else 0,
// or with `exit_status` the verdict's (verdict_exit_code). Draws a progress bar on a
// terminal, a line per 10 % elsewhere; NDJSON of every notification with --json.
int watch_scan(Session& s, std::int64_t scan, bool json_lines, bool exit_status = false);

// The README's main job (see demo.cpp).
struct DemoOptions {
  std::string state_dir;    // empty: a fresh temporary directory
  std::string goniod;       // empty: next to gonioctl
  std::string output;       // PNG path; empty: <state-dir>/demo.png
  bool keep_serving = false;
  double time_scale = 0.25; // the mock's real-time factor for motion (0: as fast as it computes)
};
int run_demo(const DemoOptions& d, const Options& o);

}  // namespace gonio::daemon::ctl
