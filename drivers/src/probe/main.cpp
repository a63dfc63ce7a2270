// gonio-probe — commissioning tool for technicians, no daemon needed:
//   gonio-probe list
//   gonio-probe scpi (--serial DEV[,BAUD] | --tcp HOST:PORT | --usbtmc VID:PID[:SERIAL])
//                    --preset gonio|pm100 (idn | measure [--wavelength NM] [--channel C])
//   gonio-probe modbus-axis (--tcp HOST:PORT | --rtu DEV[,BAUD[,8E1]]) --unit N --preset az
//                    --steps-per-degree S (status | home | move DEG)
// Exit codes: 0 ok, 1 internal, 2 usage, 3 absent, 4 timeout, 5 protocol, 6 alarm or
// saturation, 7 busy (drivers/README.md).
#include <iostream>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "gonio/drivers/probe/modbus_probe.hpp"
#include "gonio/proto/version.hpp"
#include "scpi_probe.hpp"

int main(int argc, char** argv) {
  using namespace gonio::drivers::probe;
  CLI::App app{"gonio-probe: find and check goniometer devices without the daemon"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "gonio-probe " GONIO_VERSION_STRING);
  app.footer(
      "Exit codes: 0 ok; 1 internal failure, or an interrupted move; 2 usage (nothing was sent);\n"
      "3 device absent or unreachable; 4 timeout; 5 protocol error (the device answered nonsense);\n"
      "6 device alarm (code printed; a following error is one), device error or saturation;\n"
      "7 device busy or held by another program.");
  bool verbose = false;
  app.add_flag("-v,--verbose", verbose, "log every exchange with the device");

  app.add_subcommand("list", "serial ports and USB devices (VID:PID)");

  auto* scpi = app.add_subcommand("scpi", "talk to a SCPI photometer");
  ScpiOptions so;
  long long scpi_timeout = 10000;
  auto* link = scpi->add_option_group("link");
  link->add_option("--serial", so.serial, "serial device[,baud[,8N1]]");
  link->add_option("--tcp", so.tcp, "HOST:PORT");
  link->add_option("--usbtmc", so.usbtmc, "VID:PID[:SERIAL] (hex ids)");
  link->require_option(1);
  scpi->add_option("--preset", so.preset, "command set: gonio or pm100")->check(CLI::IsMember({"gonio", "pm100"}));
  scpi->add_option("--timeout-ms", scpi_timeout, "per call")->check(CLI::Range(1, 600000));
  scpi->require_subcommand(1);
  scpi->add_subcommand("idn", "print the identity (*IDN?)");
  auto* measure = scpi->add_subcommand("measure", "take one reading and print it");
  double wl = 0;
  auto* wl_opt = measure->add_option("--wavelength", wl, "nm (pm100: required)")->check(CLI::Range(200.0, 2500.0));
  measure->add_option("--channel", so.channel, "sample, reference or dark")
      ->check(CLI::IsMember({"sample", "reference", "dark"}));

  auto* mb = app.add_subcommand("modbus-axis", "check one Modbus motion axis");
  ModbusAxisOptions mo;
  long long mb_timeout = 60000;
  auto* mlink = mb->add_option_group("link");
  mlink->add_option("--tcp", mo.tcp, "HOST:PORT");
  mlink->add_option("--rtu", mo.rtu, "DEVICE[,BAUD[,8E1]]");
  mlink->require_option(1);
  mb->add_option("--unit", mo.unit, "Modbus unit id")->required();
  mb->add_option("--preset", mo.preset, "register map preset");
  mb->add_option("--steps-per-degree", mo.steps_per_degree, "motor steps per degree")->required();
  mb->add_option("--speed", mo.speed_deg_s, "deg/s for move and home");
  mb->add_option("--timeout-ms", mb_timeout, "whole command")->check(CLI::Range(1, 3600000));
  mb->require_subcommand(1);
  mb->add_subcommand("status", "print the axis status");
  mb->add_subcommand("home", "run the homing sequence");
  auto* mv = mb->add_subcommand("move", "move to an absolute angle");
  mv->add_option("DEG", mo.target_deg, "target angle, degrees")->required();

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;
  }
  spdlog::set_level(verbose ? spdlog::level::trace : spdlog::level::warn);
  if (app.got_subcommand("list")) return run_list(std::cout, std::cerr);
  if (app.got_subcommand(scpi)) {
    so.command = scpi->get_subcommands().front()->get_name();
    if (*wl_opt) so.wavelength_nm = wl;
    so.timeout = std::chrono::milliseconds(scpi_timeout);
    return run_scpi(so, std::cout, std::cerr);
  }
  mo.command = mb->get_subcommands().front()->get_name();
  mo.timeout = std::chrono::milliseconds(mb_timeout);
  mo.verbose = verbose;
  return run_modbus_axis(mo, std::cout, std::cerr);
}
