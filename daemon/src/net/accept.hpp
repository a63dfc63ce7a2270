// What a listener (ndjson.cpp, http.cpp) does when accept() fails. Out of file
// descriptors or buffers, the pending connection stays in the backlog and accept() would fail
// again at once: the listener waits, 100 ms doubling to 2 s, instead of spinning until a
// connection closes. Any other error is logged and accepting goes on.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <string_view>
#include <utility>

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/error.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/strand.hpp>
#include <boost/asio/steady_timer.hpp>
#include <spdlog/spdlog.h>

#include "gonio/daemon/net/net.hpp"

namespace gonio::daemon::net {

// The executor a new connection's socket, timers and handlers run on: the one the context
// names, else a strand of its own on `io` (which several threads may run).
inline boost::asio::any_io_executor connection_executor(boost::asio::io_context& io, const Context& ctx) {
  if (ctx.connection_executor) return ctx.connection_executor();
  return boost::asio::make_strand(io);
}

class AcceptBackoff {
 public:
  explicit AcceptBackoff(boost::asio::any_io_executor ex) : timer_(std::move(ex)) {}

  static bool out_of_descriptors(const boost::system::error_code& ec) {
    namespace error = boost::asio::error;
    return ec == error::no_descriptors || ec == boost::system::errc::too_many_files_open_in_system ||
           ec == error::no_buffer_space || ec == error::no_memory;
  }

  // After a failed accept: runs `again` (the next accept) now or after the back-off, counting
  // each back-off in `backoffs`.
  template <class Again>
  void failed(const boost::system::error_code& ec, std::string_view endpoint,
              std::atomic<std::uint64_t>& backoffs, Again again) {
    if (!out_of_descriptors(ec)) {
      spdlog::warn("{}: accept: {}", endpoint, ec.message());
      again();
      return;
    }
    ++backoffs;
    delay_ = std::min(std::max(2 * delay_, kFirst), kMax);
    spdlog::warn("{}: accept: {}; retrying in {} ms", endpoint, ec.message(), delay_.count());
    timer_.expires_after(delay_);
    timer_.async_wait([again = std::move(again)](const boost::system::error_code& e) {
      if (!e) again();
    });
  }

  void succeeded() { delay_ = std::chrono::milliseconds(0); }
  void cancel() { timer_.cancel(); }

 private:
  static constexpr std::chrono::milliseconds kFirst{100}, kMax{2000};
  boost::asio::steady_timer timer_;
  std::chrono::milliseconds delay_{0};
};

}  // namespace gonio::daemon::net
