// `gonio-probe scpi` and `gonio-probe list`: commissioning of SCPI photometers and a look at
// what is plugged in, as functions of parsed options so that they are testable in-process.
// Exit codes are those of modbus_probe.hpp (0 ok, 1 internal, 2 usage, 3 absent,
// 4 timeout, 5 protocol, 6 alarm or saturation, 7 busy).
#pragma once

#include <chrono>
#include <iosfwd>
#include <optional>
#include <string>

namespace gonio::drivers::probe {

struct ScpiOptions {
  std::string serial;   // "DEVICE[,BAUD[,8N1]]"
  std::string tcp;      // "HOST:PORT"
  std::string usbtmc;   // "VID:PID[:SERIAL]"
  std::string preset = "gonio";
  std::string command;  // "idn" | "measure"
  std::optional<double> wavelength_nm;  // measure: one wavelength (pm100), or the channel shown
  std::string channel = "sample";       // measure: sample | reference | dark
  std::chrono::milliseconds timeout{10000};
};

int run_scpi(const ScpiOptions& options, std::ostream& out, std::ostream& err);
int run_list(std::ostream& out, std::ostream& err);

// Errc → exit code of the table above.
int exit_code_for(const std::exception& e) noexcept;

}  // namespace gonio::drivers::probe
