// gonio-devsim — stand-alone device simulators, so the real drivers run end to end without
// hardware: the AZ-compatible Modbus motion controller (TCP, and RTU on a pty) and the
// `gonio`/`pm100` SCPI photometer (pty and TCP) whose readings come from the twin.
//
// It prints one line per endpoint ("modbus-tcp 127.0.0.1:PORT", "modbus-rtu /dev/pts/N",
// "scpi-tcp 127.0.0.1:PORT", "scpi-pty /dev/pts/N"), then "ready", and runs until SIGINT or
// SIGTERM. Exit codes: 0 clean stop, 2 usage or config error, 1 anything else.
#include <csignal>
#include <fstream>
#include <iostream>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "gonio/sim/devsim/modbus_sim.hpp"
#include "gonio/sim/mock/mock.hpp"
#include "gonio/sim/devsim/scpi_sim.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/version.hpp"
#include "gonio/twin/twin.hpp"

namespace {

nlohmann::json read_json_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw gonio::Error(gonio::Errc::not_found, fmt::format("cannot open {}", path));
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw gonio::Error(gonio::Errc::parse_error, fmt::format("{}: {}", path, e.what()));
  }
}

}  // namespace

int main(int argc, char** argv) {
  using namespace gonio;
  using namespace gonio::drivers;
  CLI::App app{"gonio-devsim: Modbus motion controller and SCPI photometer simulators"};
  bool modbus_rtu = false, scpi_pty = false;
  int modbus_tcp = -1, scpi_tcp = -1;
  std::string modbus_config, scpi_config, sample = "lambert:albedo=0.5", profile = "gcms4";
  std::string host = "127.0.0.1";
  int units = 4;
  bool verbose = false;
  app.add_option("--modbus-tcp", modbus_tcp, "Modbus TCP server port (0: any free port)")->check(CLI::Range(0, 65535));
  app.add_flag("--modbus-rtu", modbus_rtu, "Modbus RTU server on a new pty");
  app.add_option("--modbus-config", modbus_config, "Modbus simulator config (JSON file)");
  app.add_option("--units", units, "simulated axes (unit ids 1..N) without --modbus-config")->check(CLI::Range(1, 16));
  app.add_option("--scpi-tcp", scpi_tcp, "SCPI photometer TCP port (0: any free port)")->check(CLI::Range(0, 65535));
  app.add_flag("--scpi-pty", scpi_pty, "SCPI photometer on a new pty");
  app.add_option("--scpi-config", scpi_config, "photometer simulator config (JSON file)");
  app.add_option("--sample", sample, "true sample BSDF spec the photometer sees");
  app.add_option("--profile", profile, "instrument profile preset or JSON file");
  app.add_option("--host", host, "address the TCP servers bind (IPv4)");
  app.add_flag("-v,--verbose", verbose, "log every request");
  app.set_version_flag("--version", "gonio-devsim " GONIO_VERSION_STRING);
  CLI11_PARSE(app, argc, argv);
  if (verbose) spdlog::set_level(spdlog::level::debug);
  if (modbus_tcp < 0 && !modbus_rtu && scpi_tcp < 0 && !scpi_pty) {
    std::cerr << "error: nothing to simulate: give --modbus-tcp, --modbus-rtu, --scpi-tcp or --scpi-pty\n";
    return 2;
  }

  // Block the stop signals before any thread starts, so that only sigwait() sees them.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  try {
    std::unique_ptr<devsim::ModbusSim> modbus;
    if (modbus_tcp >= 0 || modbus_rtu) {
      nlohmann::json cfg = modbus_config.empty() ? nlohmann::json::object() : read_json_file(modbus_config);
      if (modbus_config.empty()) {
        cfg["units"] = nlohmann::json::array();
        for (int u = 1; u <= units; ++u) cfg["units"].push_back({{"unit", u}});
      }
      if (modbus_tcp >= 0) cfg["tcp"] = {{"host", host}, {"port", modbus_tcp}};
      if (modbus_rtu) cfg["rtu"] = true;
      modbus = std::make_unique<devsim::ModbusSim>(devsim::ModbusSimConfig::from_json(cfg));
      modbus->start();
      if (modbus_tcp >= 0) std::cout << "modbus-tcp " << host << ":" << modbus->tcp_port() << "\n";
      if (modbus_rtu) std::cout << "modbus-rtu " << modbus->rtu_path() << "\n";
    }
    std::unique_ptr<devsim::ScpiSimDevice> device;
    std::unique_ptr<devsim::ScpiSimServer> server;
    if (scpi_tcp >= 0 || scpi_pty) {
      const auto cfg = devsim::ScpiSimConfig::from_json(
          scpi_config.empty() ? nlohmann::json::object() : read_json_file(scpi_config));
      const auto grid = cfg.wavelengths;
      auto tw = std::make_shared<const twin::Twin>(twin::InstrumentProfile::load(profile),
                                                   twin::make_bsdf(sample, grid), grid);
      twin::EstimatorOptions opt;
      opt.rel_se = 1e-2;
      opt.max_samples = 1u << 16;
      opt.replicates = 8;
      opt.seed = cfg.seed;
      device = std::make_unique<devsim::ScpiSimDevice>(cfg, mock::twin_beta_source(tw, opt));
      server = std::make_unique<devsim::ScpiSimServer>(*device);
      if (scpi_pty) std::cout << "scpi-pty " << server->open_pty() << "\n";
      if (scpi_tcp >= 0)
        std::cout << "scpi-tcp " << host << ":" << server->listen_tcp(host, static_cast<std::uint16_t>(scpi_tcp)) << "\n";
      server->start();
    }
    std::cout << "ready" << std::endl;
    int sig = 0;
    sigwait(&stop_signals, &sig);
    if (server) server->stop();
    if (modbus) modbus->stop();
    return 0;
  } catch (const Error& e) {
    std::cerr << "error: " << e.what() << "\n";
    return e.code() == Errc::invalid_argument || e.code() == Errc::out_of_range ||
                   e.code() == Errc::not_found || e.code() == Errc::parse_error
               ? 2
               : 1;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
