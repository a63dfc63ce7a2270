// `gonio-probe modbus-axis` — commissioning of one Modbus motion axis without the daemon.
//
//   gonio-probe modbus-axis (--tcp HOST:PORT | --rtu DEVICE[,BAUD[,8E1]]) --unit N
//                           --preset az --steps-per-degree S (status | home | move DEG)
//
// The caller (the CLI11 main) fills ModbusAxisOptions from the command line; everything
// else — parsing the link strings, checking ranges, talking to the device and wording the
// messages — happens in run_modbus_axis, so the behaviour is testable in-process.
//
// Exit codes:
//   0  success
//   1  unexpected internal failure
//   2  usage: malformed option, value out of range or unknown preset (nothing was sent)
//   3  device absent or unreachable (no such port, connection refused, link dropped)
//   4  timeout: the device did not answer, or the motion did not finish in time
//   5  protocol error: the device answered nonsense or refused the request
//   6  device alarm (the alarm code is printed; also `status` when an alarm is present),
//      or following error
//   7  device busy (not ready to accept a command)
#pragma once

#include <chrono>
#include <iosfwd>
#include <string>

namespace gonio::drivers::probe {

struct ModbusAxisOptions {
  std::string tcp;               // "HOST:PORT" ("[v6addr]:PORT" for IPv6); exclusive with rtu
  std::string rtu;               // "DEVICE[,BAUD[,FORMAT]]", FORMAT like 8E1 (default 115200,8E1)
  int unit = 1;                  // Modbus unit id (slave address), 1..247
  std::string preset = "az";     // register map preset
  double steps_per_degree = 0;   // > 0 required
  std::string command;           // "status" | "home" | "move"
  double target_deg = 0;         // for "move"
  double speed_deg_s = 10;       // for "move" and "home"
  std::chrono::milliseconds timeout{60000};  // whole command
  bool verbose = false;          // log every Modbus transaction at debug level
};

// Runs one probe command. Results go to `out`, diagnostics ("error: ...") to `err`.
int run_modbus_axis(const ModbusAxisOptions& options, std::ostream& out, std::ostream& err);

}  // namespace gonio::drivers::probe
