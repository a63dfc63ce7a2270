// ModbusLink — one libmodbus client connection (RTU on a serial line, or TCP) shared by
// every axis whose unit id lives on it.
//
// Owns the libmodbus context and sets its timing explicitly: response timeout, byte
// timeout, and protocol error recovery (flush after a bad frame); link recovery is done
// here rather than by libmodbus so that it follows the configured back-off. Every
// transaction is bounded by the caller's deadline:
//   - no answer            → retried `retries` times, then Error(timeout); a TCP link
//                            is re-opened before the retry (a late reply would otherwise
//                            be read as the answer to the next request)
//   - bad CRC / bad frame  → flushed and retried, then Error(protocol_error)
//   - Modbus exception     → Error(protocol_error) naming it (busy for "slave busy")
//   - link dropped/absent  → re-opened with exponential back-off until the deadline, then
//                            Error(disconnected); the back-off persists across calls
// Thread safety: transactions are serialised by an internal mutex, so stop() on another
// thread gets the line between two transactions of a running move.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <span>
#include <string>
#include <vector>

typedef struct _modbus modbus_t;  // libmodbus

namespace gonio::drivers::modbus {

using Clock = std::chrono::steady_clock;

struct LinkConfig {
  enum class Kind { rtu, tcp };
  std::string name;
  Kind kind = Kind::tcp;
  // tcp
  std::string host = "127.0.0.1";
  int port = 502;
  // rtu
  std::string device;
  int baud = 115200;
  char parity = 'E';  // 'N', 'E', 'O'
  int data_bits = 8;
  int stop_bits = 1;
  bool rs485 = false;  // switch the UART to RS-485 mode (TIOCSRS485)

  std::string describe() const;  // "tcp 127.0.0.1:502", "rtu /dev/ttyUSB0 115200 8E1"
};

struct LinkTiming {
  std::chrono::milliseconds response_timeout{200};
  std::chrono::milliseconds byte_timeout{50};
  int retries = 2;
  std::chrono::milliseconds backoff_initial{50};
  std::chrono::milliseconds backoff_max{2000};
};

class ModbusLink {
 public:
  ModbusLink(LinkConfig config, LinkTiming timing);
  ~ModbusLink();
  ModbusLink(const ModbusLink&) = delete;
  ModbusLink& operator=(const ModbusLink&) = delete;

  const LinkConfig& config() const noexcept { return config_; }
  std::string describe() const { return config_.describe(); }

  // Reads `count` holding registers (function 0x03).
  std::vector<std::uint16_t> read(int unit, std::uint16_t address, int count,
                                  Clock::time_point deadline);
  // Writes one register (0x06) or several (0x10). `before_send`, if given, runs while
  // the link is held, right before the request goes out, and may throw to cancel it.
  void write(int unit, std::uint16_t address, std::span<const std::uint16_t> values,
             Clock::time_point deadline, const std::function<void()>& before_send = {});

  // Drops the connection (the next transaction re-opens it).
  void close();
  // Successful connections and all connection attempts, for logs and tests.
  std::uint64_t connects() const;
  std::uint64_t connect_attempts() const;

 private:
  void ensure_connected(Clock::time_point deadline);  // mutex held
  void disconnect_locked();
  template <typename Op>
  void transact(int unit, const char* what, std::uint16_t address, Clock::time_point deadline,
                const std::function<void()>& before_send, Op op);

  LinkConfig config_;
  LinkTiming timing_;
  mutable std::mutex mutex_;
  modbus_t* ctx_ = nullptr;
  bool connected_ = false;
  Clock::time_point next_attempt_{};
  std::chrono::milliseconds backoff_{};
  std::string last_connect_error_;
  std::uint64_t connects_ = 0;
  std::uint64_t attempts_ = 0;
};

}  // namespace gonio::drivers::modbus
