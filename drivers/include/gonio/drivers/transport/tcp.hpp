// TcpTransport — a raw TCP socket (SCPI instruments listen on port 5025 by convention).
//
// Config keys (JSON): host (name or address), port (1..65535), connect_timeout_ms.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

#include "gonio/drivers/transport/transport.hpp"

namespace gonio::drivers {

struct TcpConfig {
  std::string host = "127.0.0.1";
  std::uint16_t port = 5025;
  std::chrono::milliseconds connect_timeout{3000};

  static TcpConfig read(json_util::ObjectReader& r);
  // "HOST:PORT" as on the command line ("[::1]:5025" for IPv6).
  static TcpConfig parse(std::string_view text);
  std::string describe() const;  // "127.0.0.1:5025"
};

// Connects (non-blocking connect bounded by connect_timeout). not_found: nobody listens
// (connection refused) or the host does not resolve; timeout: no answer in time.
TransportPtr open_tcp(const TcpConfig& config);

}  // namespace gonio::drivers
