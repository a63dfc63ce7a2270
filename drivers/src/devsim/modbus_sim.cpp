// ModbusSim: the AZ-compatible Modbus server — libmodbus on TCP and on a pty (RTU), one
// SimAxis per unit id, the register image kept in a libmodbus mapping per unit, faults
// and capture (behaviour documented in modbus_sim.hpp).
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
#include "gonio/proto/json_util.hpp"

namespace gonio::drivers::devsim {
namespace {

using Clock = std::chrono::steady_clock;
using modbus::RegisterMap;
using json_util::ObjectReader;

Error sys_error(const std::string& what) {
  return Error(Errc::io_error, fmt::format("modbus simulator: {}: {}", what, std::strerror(errno)));
}

std::string hex(const std::uint8_t* p, std::size_t n) {
  std::string s;
  for (std::size_t i = 0; i < n; ++i) s += fmt::format("{}{:02x}", i ? " " : "", p[i]);
  return s;
}

std::optional<SimFault> read_fault(ObjectReader& parent, const std::string& key, bool alarm) {
  const auto* j = parent.raw(key);
  if (j == nullptr) return std::nullopt;
  ObjectReader r(*j, parent.path(key));
  SimFault f;
  f.move = static_cast<int>(r.required<long long>("move"));
  if (f.move < 1 || f.move > 1000000) throw Error::out_of_range(r.path("move"), f.move, 1, 1000000);
  f.fraction = r.optional<double>("fraction", 0.5);
  if (!(f.fraction >= 0 && f.fraction <= 1)) throw Error::out_of_range(r.path("fraction"), f.fraction, 0, 1);
  if (alarm) {
    const auto code = r.optional<long long>("code", 0x30);
    if (code < 1 || code > 0xFFFF) throw Error::out_of_range(r.path("code"), static_cast<double>(code), 1, 65535);
    f.code = static_cast<std::uint32_t>(code);
  }
  r.finish();
  return f;
}

double read_range(ObjectReader& r, const std::string& key, double fallback, double lo, double hi) {
  const double v = r.optional<double>(key, fallback);
  if (!(v >= lo && v <= hi)) throw Error::out_of_range(r.path(key), v, lo, hi);
  return v;
}

}  // namespace

ModbusSimConfig ModbusSimConfig::from_json(const nlohmann::json& j) {
  ObjectReader r(j, "");
  ModbusSimConfig c;
  if (const auto* t = r.raw("tcp")) {
    ObjectReader tr(*t, "tcp");
    c.tcp_host = tr.optional<std::string>("host", "127.0.0.1");
    const auto port = tr.optional<long long>("port", 0);
    if (port < 0 || port > 65535) throw Error::out_of_range(tr.path("port"), static_cast<double>(port), 0, 65535);
    c.tcp_port = static_cast<int>(port);
    tr.finish();
  }
  c.rtu = r.optional<bool>("rtu", false);
  const auto motion = r.optional<std::string>("motion", "profile");
  if (motion != "profile" && motion != "instant")
    throw Error::invalid("motion", fmt::format("'{}' is not one of profile, instant", motion));
  c.instant = motion == "instant";
  if (const auto* m = r.raw("register_map")) c.map = RegisterMap::from_json(*m, "register_map");
  c.record_path = r.optional<std::string>("record", "");
  const auto* units = r.raw("units");
  if (units == nullptr || !units->is_array() || units->empty())
    throw Error::invalid("units", "expected a non-empty array of simulated axes");
  for (std::size_t i = 0; i < units->size(); ++i) {
    const std::string ctx = fmt::format("units[{}]", i);
    ObjectReader ur((*units)[i], ctx);
    SimAxisConfig a;
    const auto unit = ur.required<long long>("unit");
    if (unit < 1 || unit > 247) throw Error::out_of_range(ur.path("unit"), static_cast<double>(unit), 1, 247);
    a.unit = static_cast<int>(unit);
    for (const auto& other : c.units)
      if (other.unit == a.unit)
        throw Error::invalid(ur.path("unit"), fmt::format("unit {} appears twice", a.unit));
    a.position_steps = static_cast<std::int32_t>(read_range(ur, "position_steps", 0, -2147483647.0, 2147483647.0));
    a.in_position_band_steps = read_range(ur, "in_position_band_steps", 2, 0, 1e6);
    a.home_position_steps = static_cast<std::int32_t>(read_range(ur, "home_position_steps", 0, -2147483647.0, 2147483647.0));
    a.home_speed_hz = read_range(ur, "home_speed_hz", 20000, 1, 1e7);
    a.home_accel_hz_s = read_range(ur, "home_accel_hz_s", 200000, 1, 1e9);
    a.alarm_at_move = read_fault(ur, "alarm_at_move", true);
    a.stall_at_move = read_fault(ur, "stall_at_move", false);
    ur.finish();
    c.units.push_back(a);
  }
  r.finish();
  if (!c.tcp_host && !c.rtu) throw Error::invalid("tcp", "the simulator needs tcp, rtu or both");
  return c;
}

// --- the server ------------------------------------------------------------------------

struct ModbusSim::Impl {
  struct Unit {
    SimAxis axis;
    modbus_mapping_t* mapping = nullptr;
    std::uint16_t inputs = 0;  // last input command word
    Clock::time_point updated;
  };

  explicit Impl(ModbusSimConfig c) : cfg(std::move(c)) {
    int top = 0x200;
    for (const int a : {cfg.map.input_command, cfg.map.output_status, cfg.map.alarm_code,
                        cfg.map.feedback_position, cfg.map.command_position, cfg.map.trigger,
                        cfg.map.data_no, cfg.map.position, cfg.map.speed, cfg.map.rate,
                        cfg.map.stop_rate, cfg.map.current, cfg.map.operation_type})
      top = std::max(top, a + 2);
    top = std::min(top, 0x10000);
    for (const auto& a : cfg.units) {
      Unit u{SimAxis(a, cfg.instant), modbus_mapping_new_start_address(0, 0, 0, 0, 0,
                                                                       static_cast<unsigned>(top), 0, 0),
             0, Clock::now()};
      if (u.mapping == nullptr) throw Error(Errc::internal, "modbus simulator: out of memory");
      units.emplace(a.unit, std::move(u));
    }
    for (auto& [id, u] : units) sync(u);
  }

  ~Impl() {
    shutdown();
    for (auto& [id, u] : units) modbus_mapping_free(u.mapping);
  }

  // ---- register image ----
  void put32(Unit& u, std::uint16_t addr, std::uint32_t v) {
    const auto w = modbus::encode_u32(v, cfg.map.word_order);
    u.mapping->tab_registers[addr] = w[0];
    u.mapping->tab_registers[addr + 1] = w[1];
  }
  std::int32_t get_i32(const Unit& u, std::uint16_t addr) const {
    return modbus::decode_i32(u.mapping->tab_registers[addr], u.mapping->tab_registers[addr + 1],
                              cfg.map.word_order);
  }

  void sync(Unit& u) {
    modbus::StatusBits st;
    st.ready = u.axis.ready();
    st.alarm = u.axis.alarm() != 0;
    st.busy = u.axis.busy();
    st.moving = u.axis.moving();
    st.in_position = u.axis.in_position();
    st.home_end = u.axis.home_end();
    const std::uint16_t out = modbus::encode_status(st, cfg.map.output);
    u.mapping->tab_registers[cfg.map.output_status] = out;
    put32(u, cfg.map.alarm_code, u.axis.alarm());
    put32(u, cfg.map.feedback_position, static_cast<std::uint32_t>(u.axis.feedback()));
    put32(u, cfg.map.command_position, static_cast<std::uint32_t>(u.axis.command()));
  }

  void advance(Unit& u) {
    const auto now = Clock::now();
    u.axis.advance(std::chrono::duration<double>(now - u.updated).count());
    u.updated = now;
  }

  bool read_only(int first, int count) const {
    const std::array<std::pair<int, int>, 4> ro{{{cfg.map.output_status, 1},
                                                 {cfg.map.alarm_code, 2},
                                                 {cfg.map.feedback_position, 2},
                                                 {cfg.map.command_position, 2}}};
    for (const auto& [a, n] : ro)
      if (first < a + n && a < first + count) return true;
    return false;
  }

  void start_direct(Unit& u) {
    const auto& m = cfg.map;
    if (get_i32(u, m.operation_type) != m.operation_type_absolute) {
      spdlog::warn("modbus sim unit {}: operation type {} not simulated (only absolute {})",
                   u.axis.config().unit, get_i32(u, m.operation_type), m.operation_type_absolute);
      u.axis.raise_alarm(0x70);
      return;
    }
    u.axis.start_move(get_i32(u, m.position), get_i32(u, m.speed),
                      get_i32(u, m.rate) * m.rate_unit_hz_per_s,
                      get_i32(u, m.stop_rate) * m.rate_unit_hz_per_s);
  }

  // Applies what a write changed: trigger and input command.
  void after_write(Unit& u, int first, int count) {
    const auto& m = cfg.map;
    const auto touches = [&](int a, int n) { return first < a + n && a < first + count; };
    if (touches(m.input_command, 1)) {
      const std::uint16_t now = u.mapping->tab_registers[m.input_command];
      const std::uint16_t rising = static_cast<std::uint16_t>(now & ~u.inputs);
      const auto on = [&](int b) { return b >= 0 && ((now >> b) & 1u) != 0; };
      const auto rose = [&](int b) { return b >= 0 && ((rising >> b) & 1u) != 0; };
      u.inputs = now;
      u.axis.set_stop(on(m.input.stop));
      u.axis.set_free(on(m.input.free));
      if (rose(m.input.alarm_reset)) u.axis.reset_alarm();
      if (rose(m.input.zhome)) u.axis.start_home();
      if (rose(m.input.start)) start_direct(u);
    }
    if (touches(m.trigger, 2)) {
      const auto t = get_i32(u, m.trigger);
      put32(u, m.trigger, 0);
      if (t == m.trigger_value) start_direct(u);
    }
  }

  // Handles one framed request; returns false when no reply should be sent.
  bool handle(modbus_t* ctx, const std::uint8_t* req, int len, int header) {
    std::lock_guard lock(mu);
    ++requests;
    if (mute) return false;
    const int unit = req[header - 1];
    const auto it = units.find(unit);
    if (it == units.end()) return false;
    Unit& u = it->second;
    advance(u);
    sync(u);
    const int fc = req[header];
    int first = -1, count = 0;
    if (len >= header + 5) {
      if (fc == 0x06) first = (req[header + 1] << 8) | req[header + 2], count = 1;
      if (fc == 0x10) first = (req[header + 1] << 8) | req[header + 2], count = (req[header + 3] << 8) | req[header + 4];
      if (fc == 0x17 && len >= header + 9)
        first = (req[header + 5] << 8) | req[header + 6], count = (req[header + 7] << 8) | req[header + 8];
    }
    if (first >= 0 && read_only(first, count)) {
      modbus_reply_exception(ctx, req, MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
      return true;
    }
    const int rc = modbus_reply(ctx, req, len, u.mapping);
    if (rc >= 0 && first >= 0) after_write(u, first, count);
    sync(u);
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
  u.axis.raise_alarm(code);
  impl_->sync(u);
}

std::uint64_t ModbusSim::requests() const {
  std::lock_guard lock(impl_->mu);
  return impl_->requests;
}

SimAxisSnapshot ModbusSim::axis(int unit) const {
  std::lock_guard lock(impl_->mu);
  auto& u = impl_->units.at(unit);
  impl_->advance(u);
  impl_->sync(u);
  return {u.axis.command(), u.axis.feedback(), u.axis.moving(), u.axis.ready(),
          u.axis.home_end(), u.axis.alarm(), u.axis.moves_started()};
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
