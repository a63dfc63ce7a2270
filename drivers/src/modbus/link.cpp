// ModbusLink: a libmodbus client context with explicit timeouts, retries, error mapping
// to gonio::Error and reconnection with exponential back-off (see link.hpp).
#include "gonio/drivers/modbus/link.hpp"

#include <algorithm>
#include <cerrno>
#include <thread>
#include <utility>

#include <fmt/format.h>
#include <modbus/modbus.h>
#include <spdlog/spdlog.h>

#include "gonio/proto/error.hpp"

namespace gonio::drivers::modbus {
namespace {

using std::chrono::duration_cast;
using std::chrono::microseconds;
using std::chrono::milliseconds;

enum class Failure { timeout, bad_frame, exception, busy, link };

Failure classify(int err) {
  switch (err) {
    case ETIMEDOUT: return Failure::timeout;
    case EMBXSBUSY: return Failure::busy;
    case EMBBADCRC:
    case EMBBADDATA:
    case EMBBADEXC:
    case EMBUNKEXC:
    case EMBMDATA:
    case EMBBADSLAVE: return Failure::bad_frame;
    default: break;
  }
  if (err > MODBUS_ENOBASE && err <= EMBXGTAR) return Failure::exception;
  return Failure::link;  // ECONNRESET, EPIPE, EBADF, EIO, ENXIO, ...
}

void set_timeout(modbus_t* ctx, milliseconds t, bool response) {
  const auto us = std::max<long long>(duration_cast<microseconds>(t).count(), 1000);
  const auto sec = static_cast<std::uint32_t>(us / 1000000);
  const auto usec = static_cast<std::uint32_t>(us % 1000000);
  if (response) modbus_set_response_timeout(ctx, sec, usec);
  else modbus_set_byte_timeout(ctx, sec, usec);
}

milliseconds left(Clock::time_point deadline) {
  return std::max(milliseconds(0), duration_cast<milliseconds>(deadline - Clock::now()));
}

}  // namespace

std::string LinkConfig::describe() const {
  if (kind == Kind::tcp) return fmt::format("tcp {}:{}", host, port);
  return fmt::format("rtu {} {} {}{}{}", device, baud, data_bits, parity, stop_bits);
}

ModbusLink::ModbusLink(LinkConfig config, LinkTiming timing)
    : config_(std::move(config)), timing_(timing), backoff_(timing.backoff_initial) {
  if (config_.kind == LinkConfig::Kind::tcp) {
    const std::string service = std::to_string(config_.port);
    ctx_ = modbus_new_tcp_pi(config_.host.c_str(), service.c_str());
  } else {
    ctx_ = modbus_new_rtu(config_.device.c_str(), config_.baud, config_.parity, config_.data_bits,
                          config_.stop_bits);
  }
  if (ctx_ == nullptr)
    throw Error(Errc::invalid_argument,
                fmt::format("{}: libmodbus refused the link settings: {}", describe(),
                            modbus_strerror(errno)),
                config_.name);
  // Bad frames are flushed by libmodbus; the link itself is re-opened here, with back-off.
  modbus_set_error_recovery(ctx_, MODBUS_ERROR_RECOVERY_PROTOCOL);
  set_timeout(ctx_, timing_.response_timeout, true);
  set_timeout(ctx_, timing_.byte_timeout, false);
}

ModbusLink::~ModbusLink() {
  if (connected_) modbus_close(ctx_);
  modbus_free(ctx_);
}

void ModbusLink::close() {
  std::lock_guard lock(mutex_);
  disconnect_locked();
}

std::uint64_t ModbusLink::connects() const {
  std::lock_guard lock(mutex_);
  return connects_;
}

std::uint64_t ModbusLink::connect_attempts() const {
  std::lock_guard lock(mutex_);
  return attempts_;
}

void ModbusLink::disconnect_locked() {
  if (!connected_) return;
  modbus_close(ctx_);
  connected_ = false;
}

void ModbusLink::ensure_connected(Clock::time_point deadline) {
  while (!connected_) {
    const auto now = Clock::now();
    if (next_attempt_ > now) {
      if (next_attempt_ >= deadline)
        throw Error(Errc::disconnected,
                    fmt::format("{}: cannot connect: {} ({} attempts; the next, in {} ms, "
                                "would be after the deadline)",
                                describe(), last_connect_error_, attempts_,
                                duration_cast<milliseconds>(next_attempt_ - now).count()),
                    config_.name);
      std::this_thread::sleep_until(next_attempt_);
    }
    // A TCP connect is bounded by the response timeout in libmodbus.
    set_timeout(ctx_, std::min(timing_.response_timeout, std::max(left(deadline), milliseconds(1))),
                true);
    ++attempts_;
    const int rc = modbus_connect(ctx_);
    set_timeout(ctx_, timing_.response_timeout, true);
    if (rc == 0) {
      if (config_.kind == LinkConfig::Kind::rtu && config_.rs485 &&
          modbus_rtu_set_serial_mode(ctx_, MODBUS_RTU_RS485) != 0) {
        const std::string why = modbus_strerror(errno);
        modbus_close(ctx_);
        throw Error(Errc::io_error, fmt::format("{}: cannot switch to RS-485 mode: {}", describe(), why),
                    config_.name);
      }
      connected_ = true;
      ++connects_;
      backoff_ = timing_.backoff_initial;
      next_attempt_ = {};
      if (connects_ > 1) spdlog::info("modbus {}: link re-established", describe());
      return;
    }
    last_connect_error_ = modbus_strerror(errno);
    spdlog::warn("modbus {}: cannot connect ({}); retrying in {} ms", describe(),
                 last_connect_error_, backoff_.count());
    next_attempt_ = Clock::now() + backoff_;
    backoff_ = std::min(backoff_ * 2, timing_.backoff_max);
  }
}

template <typename Op>
void ModbusLink::transact(int unit, const char* what, std::uint16_t address,
                          Clock::time_point deadline, const std::function<void()>& before_send,
                          Op op) {
  // Another thread holds the link for at most one transaction (or a reconnection);
  // wait for it until the deadline. (Polled: std::timed_mutex waits through
  // pthread_mutex_clocklock, which thread sanitizers do not see.)
  while (!mutex_.try_lock()) {
    if (Clock::now() >= deadline)
      throw Error(Errc::timeout,
                  fmt::format("{}: link busy with another request until the deadline", describe()),
                  config_.name);
    std::this_thread::sleep_for(milliseconds(1));
  }
  std::unique_lock lock(mutex_, std::adopt_lock);
  int attempts = 0;
  while (true) {
    ensure_connected(deadline);
    const auto budget = left(deadline);
    if (budget <= milliseconds(0))
      throw Error(Errc::timeout,
                  fmt::format("{} unit {}: no time left for {} at 0x{:04X}", describe(), unit,
                              what, address),
                  config_.name);
    set_timeout(ctx_, std::min(timing_.response_timeout, budget), true);
    modbus_set_slave(ctx_, unit);
    if (before_send) before_send();
    errno = 0;
    if (op(ctx_) >= 0) return;
    const int err = errno;
    const Failure f = classify(err);
    const std::string why = modbus_strerror(err);
    ++attempts;
    const auto where = fmt::format("{} unit {}: {} at 0x{:04X}", describe(), unit, what, address);
    switch (f) {
      case Failure::exception:
        throw Error(Errc::protocol_error, fmt::format("{}: device refused: {}", where, why),
                    config_.name);
      case Failure::busy:
        throw Error(Errc::busy, fmt::format("{}: device busy: {}", where, why), config_.name);
      case Failure::timeout:
        if (attempts > timing_.retries || Clock::now() >= deadline)
          throw Error(Errc::timeout,
                      fmt::format("{}: no answer within {} ms ({} attempts)", where,
                                  timing_.response_timeout.count(), attempts),
                      config_.name);
        spdlog::debug("modbus {}: no answer, retrying", where);
        if (config_.kind == LinkConfig::Kind::tcp) disconnect_locked();
        else modbus_flush(ctx_);
        break;
      case Failure::bad_frame:
        if (attempts > timing_.retries || Clock::now() >= deadline)
          throw Error(Errc::protocol_error, fmt::format("{}: bad reply: {}", where, why),
                      config_.name);
        spdlog::debug("modbus {}: bad reply ({}), retrying", where, why);
        modbus_flush(ctx_);
        break;
      case Failure::link:
        spdlog::warn("modbus {}: link dropped ({})", where, why);
        disconnect_locked();
        last_connect_error_ = why;
        if (Clock::now() >= deadline)
          throw Error(Errc::disconnected, fmt::format("{}: link dropped: {}", where, why),
                      config_.name);
        break;
    }
  }
}

std::vector<std::uint16_t> ModbusLink::read(int unit, std::uint16_t address, int count,
                                            Clock::time_point deadline) {
  std::vector<std::uint16_t> out(static_cast<std::size_t>(count));
  transact(unit, "read", address, deadline, {}, [&](modbus_t* ctx) {
    const int n = modbus_read_registers(ctx, address, count, out.data());
    if (n >= 0 && n != count) {
      errno = EMBBADDATA;
      return -1;
    }
    return n;
  });
  return out;
}

void ModbusLink::write(int unit, std::uint16_t address, std::span<const std::uint16_t> values,
                       Clock::time_point deadline, const std::function<void()>& before_send) {
  transact(unit, "write", address, deadline, before_send, [&](modbus_t* ctx) {
    if (values.size() == 1) return modbus_write_register(ctx, address, values[0]);
    return modbus_write_registers(ctx, address, static_cast<int>(values.size()), values.data());
  });
}

}  // namespace gonio::drivers::modbus
