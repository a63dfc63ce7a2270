// SerialTransport — a serial line through termios in raw mode (RS-232, USB-serial
// adapters, pseudo-terminals). The port is locked with flock() so that two programs do not
// talk to one instrument at once; a locked port fails with Error(busy).
//
// Config keys (JSON): device (path), baud (50..4000000, one of the termios rates),
// data_bits (7|8), parity ("none"|"even"|"odd"), stop_bits (1|2), flow ("none"|"rtscts").
#pragma once

#include <string>

#include "gonio/drivers/transport/transport.hpp"

namespace gonio::drivers {

struct SerialConfig {
  std::string device;
  int baud = 115200;
  int data_bits = 8;
  char parity = 'N';  // 'N', 'E', 'O'
  int stop_bits = 1;
  bool rtscts = false;

  // Reads device, baud, data_bits, parity, stop_bits, flow; range-checked, field named.
  static SerialConfig read(json_util::ObjectReader& r);
  // "DEVICE[,BAUD[,8N1]]" as on the command line.
  static SerialConfig parse(std::string_view text);
  std::string describe() const;  // "/dev/ttyUSB0 115200 8N1"
};

// Opens and configures the port. not_found: no such device; busy: locked by another
// process; io_error: not a terminal or termios refused the settings.
TransportPtr open_serial(const SerialConfig& config);

}  // namespace gonio::drivers
