// goniod as a whole: wires config, store, auth, twin pool, instrument, alerts, dispatcher and
// listeners together, runs them until SIGTERM/SIGINT and shuts down cleanly (the point in
// progress is finished and committed, the running scan is parked as `interrupted`, the
// store is closed). Exit codes are listed in daemon/README.md.
#pragma once

#include <filesystem>
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

}  // namespace gonio::daemon
