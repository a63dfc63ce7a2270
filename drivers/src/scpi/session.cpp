// SCPI message exchange over any Transport: commands with a terminator, reply lines up to
// NL or USBTMC EOM, bounded length, resynchronisation after a timeout (late replies are
// dropped) and the device error queue (SYST:ERR?, SCPI-1999 Vol. 2 §21.8).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/drivers/scpi/scpi.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::drivers::scpi {

Session::Session(TransportPtr transport, SessionOptions options)
    : t_(std::move(transport)), opt_(std::move(options)) {}

void Session::command(std::string_view cmd, Deadline deadline) {
  spdlog::trace("{} <- {}", t_->describe(), cmd);
  std::string msg(cmd);
  msg += opt_.terminator;
  t_->write(msg, deadline);
}

std::string Session::read_line(Deadline deadline) {
  char chunk[4096];
  for (;;) {
    if (const auto nl = buf_.find('\n'); nl != std::string::npos) {
      std::string line = buf_.substr(0, nl);
      buf_.erase(0, nl + 1);
      return line;
    }
    if (buf_.size() > opt_.max_reply)
      throw Error(Errc::protocol_error,
                  fmt::format("{}: reply longer than {} bytes without a terminator", t_->describe(),
                              opt_.max_reply));
    const auto r = t_->read_some(chunk, deadline);
    buf_.append(chunk, r.size);
    if (r.end_of_message && buf_.find('\n') == std::string::npos) {
      std::string line = std::move(buf_);
      buf_.clear();
      return line;
    }
  }
}

std::string Session::query(std::string_view cmd, Deadline deadline) {
  buf_.clear();  // nothing unread belongs to this query
  command(cmd, deadline);
  try {
    auto line = std::string(trim(read_line(deadline)));
    spdlog::trace("{} -> {}", t_->describe(), line);
    return line;
  } catch (const Error& e) {
    if (e.code() != Errc::timeout) throw;
    // Drop whatever arrives late, then ask the device why it did not answer.
    buf_.clear();
    const auto grace = deadline_after(std::chrono::milliseconds(300));
    try {
      t_->clear(grace);
    } catch (const Error&) {
    }
    if (opt_.has_error_queue && cmd.rfind("SYST:ERR", 0) != 0) {
      std::vector<ErrorEntry> errors;
      try {
        errors = drain_errors(grace);
      } catch (const Error&) {
        throw e;
      }
      if (!errors.empty())
        throw Error(Errc::device_alarm,
                    fmt::format("{}: device rejected '{}': error {}, \"{}\"", t_->describe(), cmd,
                                errors.front().code, errors.front().message));
    }
    throw Error(Errc::timeout,
                fmt::format("{}: no reply to '{}' in time", t_->describe(), cmd));
  }
}

std::vector<ErrorEntry> Session::drain_errors(Deadline deadline) {
  std::vector<ErrorEntry> out;
  for (int i = 0; i < 32; ++i) {
    command("SYST:ERR?", deadline);
    const auto e = parse_error_entry(read_line(deadline));
    if (e.code == 0) break;
    out.push_back(e);
  }
  return out;
}

void Session::check_errors(std::string_view cmd, Deadline deadline) {
  const auto errors = drain_errors(deadline);
  if (!errors.empty())
    throw Error(Errc::device_alarm,
                fmt::format("{}: device rejected '{}': error {}, \"{}\"", t_->describe(), cmd,
                            errors.front().code, errors.front().message));
}

}  // namespace gonio::drivers::scpi
