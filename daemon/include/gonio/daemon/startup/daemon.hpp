// goniod as a whole: wires config, store, auth, twin pool, instrument, alerts, dispatcher and
// listeners together, runs them until SIGTERM/SIGINT and shuts down cleanly (the point in
// progress is finished and committed, the running scan is parked as `interrupted`, the
// store is closed). Exit codes are listed in daemon/README.md.
#pragma once

#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

namespace gonio::daemon {

namespace exit_code {
inline constexpr int ok = 0;
inline constexpr int usage = 2;        // bad option, bad config file or value
inline constexpr int state = 3;        // state dir or store unusable (permissions, newer schema)
inline constexpr int listen = 4;       // an address could not be bound
inline constexpr int internal = 70;    // a bug
}  // namespace exit_code

struct DaemonOptions {
  std::filesystem::path state_dir;
  std::optional<std::string> config_file;
  std::vector<std::string> listen;  // replaces server.listen when given
  bool mock = false;
  std::optional<std::string> log_level;
};

int run_daemon(const DaemonOptions& options);

// goniod --check-config FILE: reads FILE (with --mock, --listen and --log-level applied as
// run_daemon would), validates every key, the driver tables through the registry (opening
// no device), the instrument profile and the limits against the motion driver, and prints
// to `out` the configuration goniod would run with as TOML (every key, defaults filled in)
// followed by comments on the instrument and whether each device it names exists. Returns
// exit_code::ok, or exit_code::usage with the error (file, field, allowed range) on `err`.
int check_config(const DaemonOptions& options, std::ostream& out, std::ostream& err);

}  // namespace gonio::daemon
