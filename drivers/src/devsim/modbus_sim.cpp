// ModbusSim: the serving loop of the AZ-compatible Modbus simulator — libmodbus on TCP and
// on a pty (RTU), one SimUnit per unit id (its register behaviour is in
// modbus_sim_unit.cpp, the motion in modbus_sim_axis.cpp), faults and capture (behaviour
// documented in modbus_sim.hpp).
//
// One thread serves everything through poll(): the listening socket, the TCP clients, the
// pty master and a wake-up pipe. libmodbus frames TCP requests (modbus_receive) and builds
// every reply (modbus_reply). On RTU the requests are framed here by function code (one
// libmodbus RTU context only answers one slave id), and replies are built by libmodbus into
// a pipe, from which they are copied to the pty — so that they can be captured and, on
// request, corrupted.
#include "gonio/sim/devsim/modbus_sim.hpp"

#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <ostream>
#include <thread>

#include <fmt/format.h>
#include <modbus/modbus.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "gonio/drivers/modbus/rtu_frame.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::drivers::devsim {
namespace {

using Clock = std::chrono::steady_clock;

Error sys_error(const std::string& what) {
  return Error(Errc::io_error, fmt::format("modbus simulator: {}: {}", what, std::strerror(errno)));
}

std::string hex(const std::uint8_t* p, std::size_t n) {
  std::string s;
  for (std::size_t i = 0; i < n; ++i) s += fmt::format("{}{:02x}", i ? " " : "", p[i]);
  return s;
}

}  // namespace

// --- the server ------------------------------------------------------------------------

struct ModbusSim::Impl {
  struct Unit {
    SimUnit regs;
    Clock::time_point updated;
  };

  explicit Impl(ModbusSimConfig c) : cfg(std::move(c)) {
    for (const auto& a : cfg.units)
      units.emplace(a.unit, Unit{SimUnit(a, cfg.map, cfg.instant), Clock::now()});
  }

  ~Impl() { shutdown(); }

  void advance(Unit& u) {
    const auto now = Clock::now();
    u.regs.advance(std::chrono::duration<double>(now - u.updated).count());
    u.updated = now;
  }

  // Handles one framed request; returns false when no reply should be sent. libmodbus
  // answers it from the unit's register image; the unit then acts on what was written.
  bool handle(modbus_t* ctx, const std::uint8_t* req, int len, int header) {
    std::lock_guard lock(mu);
    ++requests;
    if (mute) return false;
    const int unit = req[header - 1];
    const auto it = units.find(unit);
    if (it == units.end()) return false;
    Unit& u = it->second;
    advance(u);
    const int fc = req[header];
    int first = -1, count = 0;
    if (len >= header + 5) {
      if (fc == 0x06) first = (req[header + 1] << 8) | req[header + 2], count = 1;
      if (fc == 0x10) first = (req[header + 1] << 8) | req[header + 2], count = (req[header + 3] << 8) | req[header + 4];
      if (fc == 0x17 && len >= header + 9)
        first = (req[header + 5] << 8) | req[header + 6], count = (req[header + 7] << 8) | req[header + 8];
    }
    if (first >= 0 && u.regs.read_only(first, count)) {
      modbus_reply_exception(ctx, req, MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
      return true;
    }
    // Holding registers only: no coils, no discrete inputs, no input registers.
    const auto image = u.regs.registers();
    modbus_mapping_t view{};
    view.nb_registers = static_cast<int>(image.size());
    view.tab_registers = image.data();
    const int rc = modbus_reply(ctx, req, len, &view);
    if (rc >= 0 && first >= 0) u.regs.written(first, count);
    return true;
  }

  // ---- endpoints ----
  void open_tcp() {
    tcp_ctx = modbus_new_tcp(cfg.tcp_host->c_str(), tcp_port);
    if (tcp_ctx == nullptr) throw sys_error("modbus_new_tcp");
    listen_fd = modbus_tcp_listen(tcp_ctx, 8);
    if (listen_fd < 0) {
      const std::string why = modbus_strerror(errno);
      throw Error(Errc::io_error, fmt::format("modbus simulator: cannot listen on {}:{}: {}",
                                              *cfg.tcp_host, tcp_port, why));
    }
    sockaddr_in addr{};
    socklen_t n = sizeof addr;
    if (getsockname(listen_fd, reinterpret_cast<sockaddr*>(&addr), &n) != 0) throw sys_error("getsockname");
    tcp_port = ntohs(addr.sin_port);
  }

  void close_tcp_listener() {
    if (listen_fd >= 0) ::close(listen_fd);
    listen_fd = -1;
    if (tcp_ctx != nullptr) modbus_free(tcp_ctx);
    tcp_ctx = nullptr;
  }

  void close_clients() {
    for (const int fd : clients) ::close(fd);
    clients.clear();
  }

  void open_rtu() {
    master_fd = posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (master_fd < 0) throw sys_error("posix_openpt");
    if (grantpt(master_fd) != 0 || unlockpt(master_fd) != 0) throw sys_error("grantpt/unlockpt");
    std::array<char, 128> name{};
    if (ptsname_r(master_fd, name.data(), name.size()) != 0) throw sys_error("ptsname_r");
    slave_path = name.data();
    // Hold the slave side open in raw mode: no echo, and the master never sees a hang-up
    // while the driver is between connections.
    slave_fd = ::open(slave_path.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (slave_fd < 0) throw sys_error("open " + slave_path);
    termios t{};
    if (tcgetattr(slave_fd, &t) == 0) {
      cfmakeraw(&t);
      tcsetattr(slave_fd, TCSANOW, &t);
    }
    std::array<int, 2> p{};
    if (pipe2(p.data(), O_CLOEXEC | O_NONBLOCK) != 0) throw sys_error("pipe2");
    reply_r = p[0];
    reply_w = p[1];
    rtu_ctx = modbus_new_rtu(slave_path.c_str(), 115200, 'E', 8, 1);
    if (rtu_ctx == nullptr) throw sys_error("modbus_new_rtu");
    modbus_set_socket(rtu_ctx, reply_w);
    if (!cfg.record_path.empty()) {
      record.open(cfg.record_path, std::ios::out | std::ios::trunc);
      if (!record) throw Error(Errc::io_error, "modbus simulator: cannot write " + cfg.record_path);
      record << "# Modbus RTU capture: '>' request to the device, '<' its reply; hex bytes "
                "including the CRC\n";
    }
  }

  void close_rtu() {
    if (rtu_ctx != nullptr) {
      modbus_set_socket(rtu_ctx, -1);
      modbus_free(rtu_ctx);
      rtu_ctx = nullptr;
    }
    for (int* fd : {&master_fd, &slave_fd, &reply_r, &reply_w})
      if (*fd >= 0) {
        ::close(*fd);
        *fd = -1;
      }
  }

  void write_all(int fd, const std::uint8_t* p, std::size_t n) {
    while (n > 0) {
      const ssize_t w = ::write(fd, p, n);
      if (w < 0) {
        if (errno == EINTR) continue;
        if (errno == EAGAIN) {
          pollfd pf{fd, POLLOUT, 0};
          ::poll(&pf, 1, 100);
          continue;
        }
        return;
      }
      p += w;
      n -= static_cast<std::size_t>(w);
    }
  }

  void serve_rtu_frame(const std::uint8_t* frame, int len) {
    if (record.is_open()) record << "> " << hex(frame, static_cast<std::size_t>(len)) << '\n';
    // libmodbus RTU: header length 1 (the address).
    const bool answer = handle(rtu_ctx, frame, len, 1);
    std::array<std::uint8_t, 512> out{};
    const ssize_t n = ::read(reply_r, out.data(), out.size());
    if (!answer || n <= 0) {
      if (record.is_open()) record.flush();
      return;
    }
    {
      std::lock_guard lock(mu);
      if (corrupt > 0) {
        --corrupt;
        out[static_cast<std::size_t>(n) - 1] ^= 0x5A;
      }
    }
    if (record.is_open()) record << "< " << hex(out.data(), static_cast<std::size_t>(n)) << '\n' << std::flush;
    write_all(master_fd, out.data(), static_cast<std::size_t>(n));
  }

  void on_rtu_readable() {
    std::array<std::uint8_t, 512> buf{};
    const ssize_t n = ::read(master_fd, buf.data(), buf.size());
    if (n <= 0) return;
    rtu_buf.insert(rtu_buf.end(), buf.begin(), buf.begin() + n);
    rtu_last = Clock::now();
    while (!rtu_buf.empty()) {
      const int need = modbus::rtu_request_length(rtu_buf);
      if (need == 0) break;
      if (need < 0) {  // unknown function: wait for the end of the frame (silence)
        break;
      }
      if (rtu_buf.size() < static_cast<std::size_t>(need)) break;
      if (need > 256 || !modbus::crc_ok(std::span(rtu_buf).first(static_cast<std::size_t>(need)))) {
        // Frame boundaries are lost: drop everything received so far.
        spdlog::debug("modbus sim: bad RTU frame dropped ({})", hex(rtu_buf.data(), rtu_buf.size()));
        std::lock_guard lock(mu);
        ++requests;
        rtu_buf.clear();
        break;
      }
      const std::vector<std::uint8_t> frame(rtu_buf.begin(), rtu_buf.begin() + need);
      rtu_buf.erase(rtu_buf.begin(), rtu_buf.begin() + need);
      serve_rtu_frame(frame.data(), need);
    }
  }

  void on_rtu_silence() {
    // A frame whose length the table cannot tell ends with the line going quiet.
    if (rtu_buf.size() >= 4 && modbus::rtu_request_length(rtu_buf) < 0 &&
        modbus::crc_ok(rtu_buf) && rtu_buf.size() <= 256) {
      const auto frame = rtu_buf;
      rtu_buf.clear();
      serve_rtu_frame(frame.data(), static_cast<int>(frame.size()));  // illegal function
      return;
    }
    rtu_buf.clear();
  }

  void on_tcp_client(std::size_t index) {
    const int fd = clients[index];
    modbus_set_socket(tcp_ctx, fd);
    std::array<std::uint8_t, MODBUS_TCP_MAX_ADU_LENGTH> req{};
    const int rc = modbus_receive(tcp_ctx, req.data());
    if (rc <= 0) {
      if (rc < 0) {
        ::close(fd);
        clients.erase(clients.begin() + static_cast<std::ptrdiff_t>(index));
      }
      return;
    }
    bool corrupt_this = false;
    {
      std::lock_guard lock(mu);
      if (corrupt > 0 && !mute) {
        --corrupt;
        corrupt_this = true;
      }
    }
    if (corrupt_this) {
      // A reply with a wrong function code and nonsense length.
      std::array<std::uint8_t, 9> bad{req[0], req[1], 0, 0, 0, 3, req[6], 0x7F, 0x00};
      {
        std::lock_guard lock(mu);
        ++requests;
      }
      write_all(fd, bad.data(), bad.size());
      return;
    }
    handle(tcp_ctx, req.data(), rc, modbus_get_header_length(tcp_ctx));
  }

  void run() {
    while (true) {
      std::vector<pollfd> fds;
      fds.push_back({wake_r, POLLIN, 0});
      {
        std::lock_guard lock(mu);
        if (pending_drop) {
          close_clients();
          pending_drop = false;
        }
        if (pending_offline && *pending_offline != offline) {
          offline = *pending_offline;
          if (offline) {
            close_clients();
            close_tcp_listener();
          } else {
            try {
              open_tcp();
            } catch (const Error& e) {
              spdlog::error("{}", e.what());
            }
          }
        }
        pending_offline.reset();
      }
      if (listen_fd >= 0) fds.push_back({listen_fd, POLLIN, 0});
      if (master_fd >= 0) fds.push_back({master_fd, POLLIN, 0});
      const std::size_t first_client = fds.size();
      for (const int c : clients) fds.push_back({c, POLLIN, 0});
      const int timeout_ms = rtu_buf.empty() ? 200 : 20;
      const int n = ::poll(fds.data(), fds.size(), timeout_ms);
      if (n < 0) {
        if (errno == EINTR) continue;
        spdlog::error("modbus simulator: poll: {}", std::strerror(errno));
        return;
      }
      if ((fds[0].revents & POLLIN) != 0) {
        std::array<char, 64> drain{};
        while (::read(wake_r, drain.data(), drain.size()) > 0) {
        }
        if (quit.load()) return;
        continue;  // re-read the fault flags
      }
      for (std::size_t i = fds.size(); i-- > first_client;)
        if ((fds[i].revents & (POLLIN | POLLHUP | POLLERR)) != 0) on_tcp_client(i - first_client);
      for (std::size_t i = 1; i < first_client; ++i) {
        if ((fds[i].revents & POLLIN) == 0) continue;
        if (fds[i].fd == listen_fd) {
          const int c = ::accept4(listen_fd, nullptr, nullptr, SOCK_CLOEXEC);
          if (c >= 0) clients.push_back(c);
        } else if (fds[i].fd == master_fd) {
          on_rtu_readable();
        }
      }
      if (!rtu_buf.empty() && Clock::now() - rtu_last > std::chrono::milliseconds(20)) on_rtu_silence();
    }
  }

  // Waits (at most 2 s) until `done` holds under the lock, while the thread serves.
  template <typename Pred>
  void await(Pred done) {
    const auto until = Clock::now() + std::chrono::seconds(2);
    while (Clock::now() < until && thread.joinable()) {
      {
        std::lock_guard lock(mu);
        if (done()) return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }

  void wake() {
    const char c = 1;
    [[maybe_unused]] const ssize_t w = ::write(wake_w, &c, 1);
  }

  void shutdown() {
    if (thread.joinable()) {
      quit = true;
      wake();
      thread.join();
    }
    close_clients();
    close_tcp_listener();
    close_rtu();
    for (int* fd : {&wake_r, &wake_w})
      if (*fd >= 0) {
        ::close(*fd);
        *fd = -1;
      }
  }

  ModbusSimConfig cfg;
  std::map<int, Unit> units;
  mutable std::mutex mu;  // units, fault flags, counters
  std::uint64_t requests = 0;
  bool mute = false;
  int corrupt = 0;
  bool pending_drop = false;
  std::optional<bool> pending_offline;
  bool offline = false;

  modbus_t* tcp_ctx = nullptr;
  int tcp_port = 0;
  int listen_fd = -1;
  std::vector<int> clients;

  modbus_t* rtu_ctx = nullptr;
  int master_fd = -1, slave_fd = -1, reply_r = -1, reply_w = -1;
  std::string slave_path;
  std::vector<std::uint8_t> rtu_buf;
  Clock::time_point rtu_last;
  std::ofstream record;

  int wake_r = -1, wake_w = -1;
  std::atomic<bool> quit{false};
  std::thread thread;
};

ModbusSim::ModbusSim(ModbusSimConfig config) : impl_(std::make_unique<Impl>(std::move(config))) {}

ModbusSim::~ModbusSim() = default;

void ModbusSim::start() {
  auto& d = *impl_;
  if (d.thread.joinable()) return;
  std::array<int, 2> p{};
  if (pipe2(p.data(), O_CLOEXEC | O_NONBLOCK) != 0) throw sys_error("pipe2");
  d.wake_r = p[0];
  d.wake_w = p[1];
  d.tcp_port = d.cfg.tcp_port;
  if (d.cfg.tcp_host) d.open_tcp();
  if (d.cfg.rtu) d.open_rtu();
  d.quit = false;
  d.thread = std::thread([&d] { d.run(); });
}

void ModbusSim::stop() { impl_->shutdown(); }

int ModbusSim::tcp_port() const { return impl_->tcp_port; }
const std::string& ModbusSim::rtu_path() const { return impl_->slave_path; }

void ModbusSim::set_mute(bool mute) {
  std::lock_guard lock(impl_->mu);
  impl_->mute = mute;
}

// Both take effect on the serving thread; they return once it has acted (bounded wait),
// so that a test's next request sees the new state.
void ModbusSim::drop_connections() {
  {
    std::lock_guard lock(impl_->mu);
    impl_->pending_drop = true;
  }
  impl_->wake();
  impl_->await([&] { return !impl_->pending_drop; });
}

void ModbusSim::set_offline(bool offline) {
  {
    std::lock_guard lock(impl_->mu);
    impl_->pending_offline = offline;
  }
  impl_->wake();
  impl_->await([&] { return !impl_->pending_offline.has_value(); });
}

void ModbusSim::corrupt_next_replies(int count) {
  std::lock_guard lock(impl_->mu);
  impl_->corrupt = count;
}

void ModbusSim::raise_alarm(int unit, std::uint32_t code) {
  std::lock_guard lock(impl_->mu);
  auto& u = impl_->units.at(unit);
  impl_->advance(u);
  u.regs.raise_alarm(code);
}

std::uint64_t ModbusSim::requests() const {
  std::lock_guard lock(impl_->mu);
  return impl_->requests;
}

SimAxisSnapshot ModbusSim::axis(int unit) const {
  std::lock_guard lock(impl_->mu);
  auto& u = impl_->units.at(unit);
  impl_->advance(u);
  const SimAxis& a = u.regs.axis();
  return {a.command(), a.feedback(), a.moving(), a.ready(), a.home_end(), a.alarm(),
          a.moves_started()};
}

int run_modbus_sim(const nlohmann::json& config, std::ostream& out, const std::atomic<bool>& stop) {
  const auto cfg = ModbusSimConfig::from_json(config);
  ModbusSim sim(cfg);
  sim.start();
  if (cfg.tcp_host) out << "modbus-tcp " << *cfg.tcp_host << ':' << sim.tcp_port() << '\n';
  if (cfg.rtu) out << "modbus-rtu " << sim.rtu_path() << '\n';
  out.flush();
  while (!stop.load()) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  sim.stop();
  return 0;
}

}  // namespace gonio::drivers::devsim
