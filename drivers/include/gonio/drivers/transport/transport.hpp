// Transport — the byte link between a driver and its device.
//
// A transport moves whole outgoing messages and reads incoming bytes. Stream links (serial
// lines, TCP sockets) have no message boundaries: the protocol layer above finds them (SCPI:
// a newline). Message links (USBTMC) also report end of message (EOM). Every call takes a
// deadline on the steady clock and fails with gonio::Error:
//   timeout       nothing (or not everything) moved before the deadline, or cancel() was called
//   disconnected  the peer closed the link or the device went away
//   io_error      any other operating-system failure (message names the call and errno text)
// Opening fails with not_found (no such device / nobody listening) or busy (in use).
#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>

#include <nlohmann/json_fwd.hpp>

namespace gonio::json_util {
class ObjectReader;
}

namespace gonio::drivers {

using Clock = std::chrono::steady_clock;
using Deadline = Clock::time_point;

inline Deadline deadline_after(std::chrono::milliseconds timeout) { return Clock::now() + timeout; }
// Milliseconds left until `d`, at least 0.
std::chrono::milliseconds remaining(Deadline d);

struct ReadResult {
  std::size_t size = 0;         // bytes placed in the buffer (>= 1)
  bool end_of_message = false;  // the device marked the end of a message (USBTMC EOM)
};

class Transport {
 public:
  virtual ~Transport() = default;
  Transport() = default;
  Transport(const Transport&) = delete;
  Transport& operator=(const Transport&) = delete;

  // Human description for logs and messages: "serial /dev/ttyUSB0 115200 8N1".
  virtual std::string describe() const = 0;
  // Sends one whole message (all bytes or an error).
  virtual void write(std::string_view message, Deadline deadline) = 0;
  // Waits for at least one byte, returns what is available up to buffer.size().
  virtual ReadResult read_some(std::span<char> buffer, Deadline deadline) = 0;
  // Drops input that nobody asked for (late replies after a timeout). Message links also
  // clear the device's buffers (USBTMC INITIATE_CLEAR).
  virtual void clear(Deadline deadline) = 0;
  // Callable from any thread: the call in progress fails soon with Error(timeout).
  virtual void cancel() noexcept = 0;
};

using TransportPtr = std::unique_ptr<Transport>;

// A device that a driver config names, as the driver would open it: what goniod
// --check-config reports without opening anything.
struct DeviceRef {
  enum class Kind { path, tcp, usb };
  Kind kind = Kind::path;
  std::string field;    // the config key that names it: "photometer.device"
  std::string address;  // "/dev/gonio/photometer", "192.168.0.10:5025", "1313:8078"
};

struct TransportSpec {
  DeviceRef device;
  std::function<TransportPtr()> open;
};

// Reads the keys a transport of `type` ("serial", "tcp", "usbtmc") owns in `r` (see
// transport/serial.hpp, transport/tcp.hpp, usbtmc/usbtmc.hpp) and returns the device and
// what opens it, so that the caller can reject unknown keys (r.finish()) before any device
// is touched, or check a config without opening it at all.
TransportSpec read_transport(std::string_view type, json_util::ObjectReader& r);

}  // namespace gonio::drivers
