// SCPI message exchange over any Transport: commands with a terminator, reply lines up to
// NL or USBTMC EOM, bounded length, resynchronisation after a timeout or a broken reply
// (late replies are dropped, never taken for the next query's; scpi.hpp) and the device
// error queue (SYST:ERR?, SCPI-1999 Vol. 2 §21.8).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/drivers/scpi/scpi.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::drivers::scpi {
namespace {

// Lines one resynchronisation may drop before it gives up: a device that keeps talking
// is not one we can get back in step with.
constexpr int kMaxDroppedLines = 256;

}  // namespace

Session::Session(TransportPtr transport, SessionOptions options)
    : t_(std::move(transport)), opt_(std::move(options)) {}

void Session::send(std::string_view cmd, Deadline deadline) {
  spdlog::trace("{} <- {}", t_->describe(), cmd);
  std::string msg(cmd);
  msg += opt_.terminator;
  t_->write(msg, deadline);
}

void Session::command(std::string_view cmd, Deadline deadline) {
  if (!buf_.empty()) out_of_step_ = true;  // lines nobody asked for: whose reply are they?
  resync(deadline);
  try {
    send(cmd, deadline);
  } catch (const Error&) {
    out_of_step_ = true;  // part of the message may have gone out
    throw;
  }
}

std::string Session::read_line(Deadline deadline) {
  char chunk[4096];
  for (;;) {
    if (const auto nl = buf_.find('\n'); nl != std::string::npos) {
      std::string line = buf_.substr(0, nl);
      buf_.erase(0, nl + 1);
      return line;
    }
    if (buf_.size() > opt_.max_reply) {
      out_of_step_ = true;
      throw Error(Errc::protocol_error,
                  fmt::format("{}: reply longer than {} bytes without a terminator", t_->describe(),
                              opt_.max_reply));
    }
    const auto r = t_->read_some(chunk, deadline);
    buf_.append(chunk, r.size);
    if (r.end_of_message && buf_.find('\n') == std::string::npos) {
      std::string line = std::move(buf_);
      buf_.clear();
      return line;
    }
  }
}

void Session::resync(Deadline deadline) {
  if (!out_of_step_) return;
  try {
    buf_.clear();
    // USBTMC: device clear; streams: drop what has arrived. Not while markers of an earlier
    // attempt are unanswered: their "1" may be among the bytes dropped, and then counting
    // them would wait for an answer that never comes.
    if (markers_ == 0) t_->clear(deadline);
    send("*OPC?", deadline);
    ++markers_;
    int dropped = 0;
    while (markers_ > 0) {
      const auto line = std::string(trim(read_line(deadline)));
      if (line == "1") {
        --markers_;
        continue;
      }
      spdlog::debug("{}: dropped a late reply while resynchronising: '{}'", t_->describe(),
                    line.substr(0, 80));
      if (++dropped > kMaxDroppedLines)
        throw Error(Errc::protocol_error, "the device keeps sending");
    }
    out_of_step_ = false;
    spdlog::debug("{}: session resynchronised", t_->describe());
  } catch (const Error& e) {
    throw Error(Errc::disconnected,
                fmt::format("{}: cannot resynchronise the session after a failed exchange ({}); "
                            "the device must be reopened",
                            t_->describe(), e.what()));
  }
}

std::string Session::query(std::string_view cmd, Deadline deadline) {
  command(cmd, deadline);
  try {
    auto line = std::string(trim(read_line(deadline)));
    spdlog::trace("{} -> {}", t_->describe(), line);
    return line;
  } catch (const Error& e) {
    out_of_step_ = true;
    if (e.code() != Errc::timeout) throw;
    // Get back in step (a late reply is dropped), then ask the device why it did not answer.
    // If that does not work within a short grace, the next exchange tries again with its
    // own deadline.
    const auto grace = deadline_after(std::chrono::milliseconds(300));
    try {
      resync(grace);
    } catch (const Error&) {
      throw Error(Errc::timeout, fmt::format("{}: no reply to '{}' in time", t_->describe(), cmd));
    }
    if (opt_.has_error_queue && cmd.rfind("SYST:ERR", 0) != 0) {
      std::vector<ErrorEntry> errors;
      try {
        errors = drain_errors_in_step(grace);
      } catch (const Error&) {
        out_of_step_ = true;
      }
      if (!errors.empty())
        throw Error(Errc::device_alarm,
                    fmt::format("{}: device rejected '{}': error {}, \"{}\"", t_->describe(), cmd,
                                errors.front().code, errors.front().message));
    }
    throw Error(Errc::timeout, fmt::format("{}: no reply to '{}' in time", t_->describe(), cmd));
  }
}

std::vector<ErrorEntry> Session::drain_errors_in_step(Deadline deadline) {
  std::vector<ErrorEntry> out;
  for (int i = 0; i < 32; ++i) {
    const auto e = parse_error_entry(query("SYST:ERR?", deadline));
    if (e.code == 0) break;
    out.push_back(e);
  }
  return out;
}

std::vector<ErrorEntry> Session::drain_errors(Deadline deadline) {
  try {
    return drain_errors_in_step(deadline);
  } catch (const Error& e) {
    if (e.code() == Errc::protocol_error) out_of_step_ = true;  // not an error entry: whose?
    throw;
  }
}

void Session::check_errors(std::string_view cmd, Deadline deadline) {
  const auto errors = drain_errors(deadline);
  if (!errors.empty())
    throw Error(Errc::device_alarm,
                fmt::format("{}: device rejected '{}': error {}, \"{}\"", t_->describe(), cmd,
                            errors.front().code, errors.front().message));
}

}  // namespace gonio::drivers::scpi
