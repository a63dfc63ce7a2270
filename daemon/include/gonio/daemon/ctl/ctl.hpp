// gonioctl — every goniod method from the shell (daemon/README.md lists the commands).
//
// Human tables by default, --json for scripts; `scan watch` draws a live progress bar with
// the ETA and a running divergence count; `demo` runs the README's main job end to end.
// Exit codes (ctl_exit): 0 ok, 1 other server error, 2 usage or invalid params, 3 cannot
// connect / connection lost, 4 unauthorized or forbidden, 5 not found, 6 invalid state or
// instrument busy, 7 instrument fault or limit violation, 8 plan rejected, 9 a watched scan
// ended other than completed, 70 internal error. With --exit-status, a watched scan that
// completed exits with its verdict: 10 out_of_tolerance, 11 instrument_out_of_spec (0 for
// agrees and undecided) — results, not errors, so they stay apart from the codes above.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace gonio::daemon {

namespace ctl_exit {
inline constexpr int ok = 0;
inline constexpr int server = 1;
inline constexpr int usage = 2;
inline constexpr int connection = 3;
inline constexpr int auth = 4;
inline constexpr int not_found = 5;
inline constexpr int state = 6;
inline constexpr int instrument = 7;
inline constexpr int plan = 8;
inline constexpr int scan_not_completed = 9;
inline constexpr int out_of_tolerance = 10;
inline constexpr int instrument_out_of_spec = 11;
inline constexpr int internal = 70;
}  // namespace ctl_exit

// The exit code for a JSON-RPC error code.
int exit_code_for_rpc(int code) noexcept;

// A plain text table: a header row and aligned columns (numbers right-aligned).
class Table {
 public:
  explicit Table(std::vector<std::string> header) : header_(std::move(header)) {}
  void add(std::vector<std::string> row) { rows_.push_back(std::move(row)); }
  std::string render() const;
  std::size_t size() const noexcept { return rows_.size(); }

 private:
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
};

// "[##########··········]  45/81  56 %  ETA 0:12  diverged 2" (width in cells of the bar).
std::string progress_bar(std::size_t done, std::size_t total, double eta_s, std::size_t diverged,
                         int width = 30);
// 0:05, 1:02:03
std::string format_duration(double seconds);
// A JSON value as a table cell ("-" for null, numbers with up to 4 significant digits).
std::string cell(const nlohmann::json& v);

int gonioctl_main(int argc, char** argv);

}  // namespace gonio::daemon
