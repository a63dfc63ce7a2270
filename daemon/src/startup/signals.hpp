// What watches goniod while it serves (startup/daemon.cpp): systemd's watchdog, and the
// signals that stop it (SIGTERM, SIGINT) and reload its TLS certificate (SIGHUP).
#pragma once

#include <systemd/sd-daemon.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <memory>
#include <thread>
#include <vector>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <spdlog/spdlog.h>

#include "gonio/daemon/config/config.hpp"
#include "gonio/daemon/instrument/instrument.hpp"
#include "gonio/daemon/net/net.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {

// systemd's watchdog, when the unit has one: petted at half its period while the
// instrument thread is alive too, allowing for the longest device call.
class Watchdog {
 public:
  Watchdog(boost::asio::io_context& io, const Config& config, const Instrument& instrument)
      : timer_(io), instrument_(instrument),
        stale_(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
            std::max({config.move_timeout, config.home_timeout, config.measure_timeout}) +
            std::chrono::seconds(10))) {}

  void start() {
    std::uint64_t us = 0;
    if (sd_watchdog_enabled(0, &us) <= 0 || us == 0) return;
    period_ = std::chrono::microseconds(us / 2);
    pet();
  }

 private:
  void pet() {
    if (std::chrono::steady_clock::now() - instrument_.heartbeat() < stale_) sd_notify(0, "WATCHDOG=1");
    else spdlog::error("watchdog: the instrument thread has not run for too long");
    timer_.expires_after(period_);
    timer_.async_wait([this](const boost::system::error_code& ec) {
      if (!ec) pet();
    });
  }

  boost::asio::steady_timer timer_;
  const Instrument& instrument_;
  std::chrono::steady_clock::duration stale_;
  std::chrono::microseconds period_{0};
};

// SIGTERM and SIGINT: the listeners close, the point in progress is finished and the scan
// parked, then the io threads stop. Parking may wait for a device: it runs on a thread of
// its own, off the network threads. Connections asked to close get up to kCloseGrace more
// to end (a WebSocket's peer answers the server's Close frame); one that has not is cut off.
constexpr auto kCloseGrace = std::chrono::seconds(2);

class StopOnSignal {
 public:
  StopOnSignal(boost::asio::io_context& io, std::vector<std::shared_ptr<net::Listener>>& listeners,
               Instrument& instrument)
      : io_(io), signals_(io, SIGINT, SIGTERM), listeners_(listeners), instrument_(instrument) {
    signals_.async_wait([this](const boost::system::error_code& ec, int sig) {
      if (ec || stopping_) return;
      stopping_ = true;
      spdlog::info("{}: stopping (finishing the point in progress)", sig == SIGTERM ? "SIGTERM" : "SIGINT");
      sd_notify(0, "STOPPING=1\nSTATUS=stopping");
      for (auto& l : listeners_) l->close();
      stopper_ = std::thread([this] {
        instrument_.shutdown();
        const auto closing = [this] {
          return std::any_of(listeners_.begin(), listeners_.end(), [](const auto& l) { return l->closing(); });
        };
        for (const auto end = std::chrono::steady_clock::now() + kCloseGrace;
             closing() && std::chrono::steady_clock::now() < end;)
          std::this_thread::sleep_for(std::chrono::milliseconds(5));
        io_.stop();
      });
    });
  }
  void join() {
    if (stopper_.joinable()) stopper_.join();
  }

 private:
  boost::asio::io_context& io_;
  boost::asio::signal_set signals_;
  std::vector<std::shared_ptr<net::Listener>>& listeners_;
  Instrument& instrument_;
  bool stopping_ = false;
  std::thread stopper_;
};

// SIGHUP: the TLS listeners' certificate and key are read again (a renewed certificate put
// in place of the old one). New handshakes use them; connections already up keep theirs. A
// file that does not pass the checks of --check-config is logged and the old ones stay.
class ReloadOnSignal {
 public:
  ReloadOnSignal(boost::asio::io_context& io, std::shared_ptr<net::TlsServer> tls)
      : signals_(io, SIGHUP), tls_(std::move(tls)) {
    wait();
  }

 private:
  void wait() {
    signals_.async_wait([this](const boost::system::error_code& ec, int) {
      if (ec) return;
      if (!tls_) {
        spdlog::info("SIGHUP: nothing to reload (no [server.tls])");
      } else {
        try {
          net::reload_tls(*tls_);
          spdlog::info("SIGHUP: reloaded the TLS certificate and key; new connections use them");
        } catch (const Error& e) {
          spdlog::error("SIGHUP: kept the TLS certificate in use: {}", e.what());
        }
      }
      wait();
    });
  }

  boost::asio::signal_set signals_;
  std::shared_ptr<net::TlsServer> tls_;
};

}  // namespace gonio::daemon
