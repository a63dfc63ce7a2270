// goniod — the gonio service: schedules and runs scans, stores measured and predicted points
// side by side, raises divergence alerts, and serves JSON-RPC (daemon/README.md).
#include <iostream>

#include <CLI/CLI.hpp>

#include "gonio/daemon/startup/daemon.hpp"
#include "gonio/daemon/startup/restore.hpp"
#include "gonio/proto/version.hpp"

int main(int argc, char** argv) {
  CLI::App app{"goniod — goniometric spectrophotometer service with a digital twin"};
  gonio::daemon::DaemonOptions o;
  std::string state_dir;
  std::string check_file;
  auto* state_opt =
      app.add_option("--state-dir", state_dir, "directory for the store, the socket and admin.token");
  app.add_option("--config", o.config_file, "TOML configuration file");
  auto* check_opt = app.add_option("--check-config", check_file,
                                   "validate FILE, print the configuration goniod would run with "
                                   "and exit (0: valid, 2: not)")
                        ->excludes("--config")
                        ->excludes(state_opt);
  std::string restore_file;
  auto* restore_opt = app.add_option("--restore", restore_file,
                                     "make the backup FILE (gonioctl backup) the store of --state-dir, "
                                     "which must be empty or absent, and exit")
                          ->excludes(check_opt);
  app.add_option("--listen", o.listen,
                 "unix:PATH, tcp://HOST:PORT, http://HOST:PORT, tls://HOST:PORT or "
                 "https://HOST:PORT (repeatable; replaces server.listen)");
  app.add_flag("--mock", o.mock, "use the built-in twin-backed mock instrument");
  app.add_option("--log-level", o.log_level, "trace, debug, info, warn, error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
  app.set_version_flag("--version", "goniod " GONIO_VERSION_STRING);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : gonio::daemon::exit_code::usage;
  }
  if (*check_opt) {
    o.config_file = check_file;
    return gonio::daemon::check_config(o, std::cout, std::cerr);
  }
  if (!*state_opt) {
    std::cerr << "--state-dir is required\nRun with --help for more information.\n";
    return gonio::daemon::exit_code::usage;
  }
  if (*restore_opt) return gonio::daemon::restore_state(restore_file, state_dir, std::cout, std::cerr);
  o.state_dir = state_dir;
  return gonio::daemon::run_daemon(o);
}
