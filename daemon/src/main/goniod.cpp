// goniod — the gonio service: schedules and runs scans, stores measured and predicted points
// side by side, raises divergence alerts, and serves JSON-RPC (daemon/README.md).
#include <CLI/CLI.hpp>

#include "gonio/daemon/daemon.hpp"
#include "gonio/proto/version.hpp"

int main(int argc, char** argv) {
  CLI::App app{"goniod — goniometric spectrophotometer service with a digital twin"};
  gonio::daemon::DaemonOptions o;
  std::string state_dir;
  app.add_option("--state-dir", state_dir, "directory for the store, the socket and admin.token")
      ->required();
  app.add_option("--config", o.config_file, "TOML configuration file");
  app.add_option("--listen", o.listen,
                 "unix:PATH, tcp://HOST:PORT or http://HOST:PORT (repeatable; replaces "
                 "server.listen)");
  app.add_flag("--mock", o.mock, "use the built-in twin-backed mock instrument");
  app.add_option("--log-level", o.log_level, "trace, debug, info, warn, error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
  app.set_version_flag("--version", "goniod " GONIO_VERSION_STRING);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : gonio::daemon::exit_code::usage;
  }
  o.state_dir = state_dir;
  return gonio::daemon::run_daemon(o);
}
