// gonio-load — latency and throughput of goniod under concurrent clients, during a running
// mock scan, beside a raw loopback echo server measured in the same run (the floor that
// the machine and the client code set).
//
// By default it starts `goniod --mock` in a fresh temporary state dir with a TCP listener on
// 127.0.0.1, creates a sample and submits a long scan, waits until points are stored, and
// then, for each target in turn, runs N client threads (one connection each) that send
// requests back to back for a fixed time:
//   echo         a line echoed by an in-process epoll server (no JSON-RPC work at all)
//   system.info  goniod's cheapest method that touches every service
//   scan.points  a page of 10 stored points of the running scan (SQLite read + JSON)
// It prints p50 / p99 / max latency, throughput and errors per target, the server's own CPU
// time per request (the echo thread's; goniod's, less what it spends with no client, the
// running scan's), goniod's resident memory and the scan runner's own time per point
// (excluding motion, photometer and twin). The clients check each answer's id and error
// without building it (Client::call_checked), so that their own allocation of 64 answer
// trees on the same cores is not what is measured; --parse-replies parses every answer whole,
// as gonioctl does.
// Wall times are measured, never asserted.
//
// --hostile adds what an attacker (or a clumsy script) does, against a goniod it started
// itself, and reports goniod's peak RSS (VmHWM) in each phase, the peak reset to the RSS at
// its start (and that RSS beside it), so that a phase's peak is its own and not that of the
// load phases before it:
//   single   one request at a time, each up to max_message_bytes: a 1 MB batch of
//            rpc.discover and one of {} (no login), a 1 MB line of tiny values, the largest
//            allowed batch of rpc.discover, 128 pages of 1000 points, a scan.export
//   flood    64 clients at once for --seconds, each in a loop picking one of: the requests
//            above; pipelining rpc.discover without reading the answers; a line that never
//            ends; connecting without logging in
//   control  32 viewers hammering scan.export while a technician pauses and resumes a
//            queued scan: the latency of scan.pause
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/resource.h>
#include <pthread.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/daemon/config/config.hpp"
#include "gonio/daemon/ctl/client.hpp"
#include "gonio/daemon/ctl/ctl.hpp"

namespace fs = std::filesystem;
using gonio::daemon::Client;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

// A line echo server on 127.0.0.1 (ephemeral port), one epoll thread. Given a result, it
// replays instead: each request line gets {"jsonrpc":"2.0","id":ID,"result":RESULT}, its own
// id and always the same result, so that the same bytes as goniod's answer cross the socket
// and reach the client with no work behind them.
class EchoServer {
 public:
  explicit EchoServer(std::string result = {}) : result_(std::move(result)) {
    listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = 0;
    if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(listen_fd_, 1024) != 0)
      throw std::runtime_error(fmt::format("echo server: {}", std::strerror(errno)));
    socklen_t len = sizeof a;
    ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
    ::pipe2(stop_, O_CLOEXEC);
    thread_ = std::thread([this] { run(); });
  }
  ~EchoServer() {
    (void)!::write(stop_[1], "x", 1);
    thread_.join();
    ::close(listen_fd_);
    ::close(stop_[0]);
    ::close(stop_[1]);
  }
  std::string uri() const { return fmt::format("tcp://127.0.0.1:{}", port_); }
  // CPU time of the server thread so far.
  double cpu_seconds() {
    clockid_t id;
    timespec ts{};
    if (::pthread_getcpuclockid(thread_.native_handle(), &id) != 0 || ::clock_gettime(id, &ts) != 0) return NAN;
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
  }

 private:
  void run() {
    const int ep = ::epoll_create1(EPOLL_CLOEXEC);
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.fd = listen_fd_;
    ::epoll_ctl(ep, EPOLL_CTL_ADD, listen_fd_, &ev);
    ev.data.fd = stop_[0];
    ::epoll_ctl(ep, EPOLL_CTL_ADD, stop_[0], &ev);
    std::map<int, std::string> pending;
    std::vector<epoll_event> events(256);
    char buf[65536];
    for (;;) {
      const int n = ::epoll_wait(ep, events.data(), static_cast<int>(events.size()), -1);
      for (int i = 0; i < n; ++i) {
        const int fd = events[static_cast<std::size_t>(i)].data.fd;
        if (fd == stop_[0]) {
          for (auto& [c, b] : pending) ::close(c);
          ::close(ep);
          return;
        }
        if (fd == listen_fd_) {
          for (;;) {
            const int c = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
            if (c < 0) break;
            epoll_event ce{};
            ce.events = EPOLLIN;
            ce.data.fd = c;
            ::epoll_ctl(ep, EPOLL_CTL_ADD, c, &ce);
            pending[c];
          }
          continue;
        }
        const auto r = ::recv(fd, buf, sizeof buf, 0);
        if (r <= 0) {
          ::epoll_ctl(ep, EPOLL_CTL_DEL, fd, nullptr);
          ::close(fd);
          pending.erase(fd);
          continue;
        }
        auto& b = pending[fd];
        b.append(buf, static_cast<std::size_t>(r));
        const auto nl = b.rfind('\n');
        if (nl == std::string::npos) continue;
        // The client waits for each answer, so a blocking send of one line is fine.
        if (result_.empty()) (void)!::send(fd, b.data(), nl + 1, MSG_NOSIGNAL);
        else replay(fd, std::string_view(b).substr(0, nl + 1));
        b.erase(0, nl + 1);
      }
    }
  }
  // Client::call_checked's requests start {"jsonrpc":"2.0","id":N,...
  void replay(int fd, std::string_view lines) {
    for (std::size_t start = 0, nl; (nl = lines.find('\n', start)) != std::string_view::npos; start = nl + 1) {
      const auto line = lines.substr(start, nl - start);
      const auto at = line.find(R"("id":)");
      const auto id = at == std::string_view::npos ? std::string_view("null")
                                                   : line.substr(at + 5, line.find_first_of(",}", at) - at - 5);
      out_.clear();
      ((((out_ += R"({"jsonrpc":"2.0","id":)") += id) += R"(,"result":)") += result_) += "}\n";
      (void)!::send(fd, out_.data(), out_.size(), MSG_NOSIGNAL);
    }
  }

  std::string result_, out_;
  int listen_fd_ = -1;
  int stop_[2]{-1, -1};
  std::uint16_t port_ = 0;
  std::thread thread_;
};

struct Result {
  std::string target;
  std::size_t clients = 0, requests = 0, errors = 0;
  double seconds = 0;
  double server_cpu_s = NAN;  // the server's CPU time during the run (NAN: not known)
  std::vector<double> latency_ms;
};

double quantile(std::vector<double>& v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

// ---- hostile clients ---------------------------------------------------------------------

// A raw NDJSON connection: writes whatever it is given and reads lines (or not).
class Raw {
 public:
  explicit Raw(const std::string& uri) {
    const auto colon = uri.rfind(':');
    const int port = std::stoi(uri.substr(colon + 1));
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
      ::close(fd_);
      throw std::runtime_error(fmt::format("connect: {}", std::strerror(errno)));
    }
    timeval tv{10, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    ::setsockopt(fd_, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  }
  ~Raw() { ::close(fd_); }
  Raw(const Raw&) = delete;
  Raw& operator=(const Raw&) = delete;
  bool send(const std::string& bytes) {
    std::size_t off = 0;
    while (off < bytes.size()) {
      const auto n = ::send(fd_, bytes.data() + off, bytes.size() - off, MSG_NOSIGNAL);
      if (n <= 0) return false;
      off += static_cast<std::size_t>(n);
    }
    return true;
  }
  // One line; empty on close or timeout.
  std::string line() {
    for (;;) {
      if (const auto nl = buf_.find('\n'); nl != std::string::npos) {
        auto l = buf_.substr(0, nl);
        buf_.erase(0, nl + 1);
        return l;
      }
      char b[65536];
      const auto n = ::recv(fd_, b, sizeof b, 0);
      if (n <= 0) return {};
      buf_.append(b, static_cast<std::size_t>(n));
    }
  }
  std::string call(const std::string& method, const json& params) {
    send(json{{"jsonrpc", "2.0"}, {"id", 1}, {"method", method}, {"params", params}}.dump() + "\n");
    return line();
  }

 private:
  int fd_ = -1;
  std::string buf_;
};

// A memory figure of a process's /proc/PID/status (a "kB" line such as "VmHWM:") in MiB;
// NAN when unknown.
double status_mib(pid_t pid, std::string_view field) {
  std::ifstream in(fmt::format("/proc/{}/status", pid));
  std::string l;
  while (std::getline(in, l))
    if (l.starts_with(field)) return std::stod(l.substr(field.size())) / 1024.0;
  return NAN;
}
double peak_rss_mib(pid_t pid) { return status_mib(pid, "VmHWM:"); }
double rss_mib(pid_t pid) { return status_mib(pid, "VmRSS:"); }

// Resets the peak (VmHWM) to the current RSS: "5" to /proc/PID/clear_refs (proc(5), Linux
// 4.0 and later). False when refused: the peak then covers the process's whole life.
bool reset_peak_rss(pid_t pid) {
  std::ofstream out(fmt::format("/proc/{}/clear_refs", pid));
  out << "5";
  out.flush();
  return static_cast<bool>(out);
}

std::string batch_of(const std::string& element, std::size_t bytes) {
  std::string b = "[";
  while (b.size() + element.size() + 2 < bytes) {
    if (b.size() > 1) b += ',';
    b += element;
  }
  return b + "]\n";
}

struct Hostile {
  Hostile(std::string u, std::string t, std::int64_t s) : uri(std::move(u)), token(std::move(t)), scan(s) {}
  std::string uri, token;
  std::int64_t scan = 0;
  std::string discover_batch = batch_of(R"({"jsonrpc":"2.0","id":1,"method":"rpc.discover"})", 1000000);
  std::string empty_batch = batch_of("{}", 1000000);
  std::string values_line = [] {
    std::string z(999000, '0');
    for (std::size_t i = 1; i < z.size(); i += 2) z[i] = ',';
    return R"({"jsonrpc":"2.0","id":1,"method":"rpc.discover","params":{"x":[)" + z + "0]}}\n";
  }();
  std::string max_batch = [] {
    std::string b = "[";
    for (int i = 0; i < 128; ++i) b += fmt::format("{}{{\"jsonrpc\":\"2.0\",\"id\":{},\"method\":\"rpc.discover\"}}", i ? "," : "", i);
    return b + "]\n";
  }();
  std::string pages_batch(std::int64_t s) const {
    std::string b = "[";
    for (int i = 0; i < 128; ++i)
      b += (i ? "," : "") + json{{"jsonrpc", "2.0"}, {"id", i}, {"method", "scan.points"},
                                  {"params", {{"scan", s}, {"limit", 1000}}}}.dump();
    return b + "]\n";
  }

  // One hostile act (kind 0..8) on a fresh connection; returns when it is over.
  void act(int kind) const {
    Raw r(uri);
    const auto login = [&] { r.call("auth.login", json{{"token", token}}); };
    switch (kind) {
      case 0: r.send(discover_batch), r.line(); break;
      case 1: r.send(empty_batch), r.line(); break;
      case 2: r.send(values_line), r.line(); break;
      case 3: r.send(max_batch), r.line(); break;
      case 4: login(), r.send(pages_batch(scan)), r.line(); break;
      case 5: login(), r.call("scan.export", json{{"scan", scan}, {"format", "json"}}); break;
      case 6: {  // pipelines without reading the answers, then lingers
        login();
        std::string lines;
        for (int i = 0; i < 200; ++i) lines += R"({"jsonrpc":"2.0","id":1,"method":"rpc.discover"})" "\n";
        r.send(lines);
        std::this_thread::sleep_for(std::chrono::seconds(2));
        break;
      }
      case 7:  // a line that never ends
        r.send(R"({"jsonrpc":"2.0","id":1,"method":"rpc.discover","params":{"pad":")" + std::string(500000, 'x'));
        std::this_thread::sleep_for(std::chrono::seconds(2));
        break;
      default:  // connects and says nothing
        std::this_thread::sleep_for(std::chrono::seconds(2));
        break;
    }
  }
};

// One method per client, taken in turn from `calls` (client i makes calls[i % n]).
using Calls = std::vector<std::pair<std::string, json>>;

// Nice increment of the client threads (--client-nice): clients on other machines take no
// CPU from goniod; on the same machine, a positive value stands for that.
int g_client_nice = 0;
// --parse-replies: every answer parsed whole (Client::call) instead of checked.
bool g_parse_replies = false;
// --ca: the CA of a tls:// goniod (--connect).
std::string g_ca;

// User + system CPU time of a process so far (/proc/PID/stat, proc(5) fields 14 and 15).
double process_cpu_seconds(pid_t pid) {
  std::ifstream in(fmt::format("/proc/{}/stat", pid));
  std::string stat((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto close = stat.rfind(')');
  if (close == std::string::npos) return NAN;
  std::istringstream rest(stat.substr(close + 2));
  std::string field;
  double ticks = 0;
  for (int i = 3; i <= 15 && rest >> field; ++i)
    if (i >= 14) ticks += std::stod(field);
  return ticks / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

Result run_clients(const std::string& target, const std::string& uri, const std::string& token,
                   std::size_t clients, double seconds, const Calls& calls) {
  Result res;
  res.target = target;
  res.clients = clients;
  std::vector<std::vector<double>> lat(clients);
  std::vector<std::size_t> errs(clients, 0);
  std::atomic<std::size_t> ready{0};
  std::atomic<bool> go{false}, failed_connect{false};
  std::vector<std::thread> threads;
  Clock::time_point t_end;
  for (std::size_t i = 0; i < clients; ++i)
    threads.emplace_back([&, i] {
      if (g_client_nice > 0) ::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), g_client_nice);
      std::optional<Client> c;
      try {
        c.emplace(uri, std::chrono::seconds(10), g_ca);
        if (!token.empty()) c->login(token);
      } catch (const std::exception& e) {
        std::cerr << "gonio-load: client " << i << ": " << e.what() << "\n";
        failed_connect = true;
      }
      ++ready;
      while (!go.load()) std::this_thread::yield();
      if (!c) return;
      lat[i].reserve(100000);
      const auto& [method, params] = calls[i % calls.size()];
      while (Clock::now() < t_end) {
        const auto t0 = Clock::now();
        try {
          if (g_parse_replies) c->call(method, params);
          else c->call_checked(method, params);
          lat[i].push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
        } catch (const std::exception&) {
          ++errs[i];
          if (errs[i] > 1000) break;
        }
      }
    });
  while (ready.load() < clients) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  const auto t0 = Clock::now();
  t_end = t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  go = true;
  for (auto& t : threads) t.join();
  res.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  for (std::size_t i = 0; i < clients; ++i) {
    res.latency_ms.insert(res.latency_ms.end(), lat[i].begin(), lat[i].end());
    res.errors += errs[i];
  }
  res.requests = res.latency_ms.size();
  if (failed_connect) res.errors += 1;
  return res;
}

// Adds a round's figures to those of the earlier rounds of the same target.
void pool(Result& into, Result r) {
  if (into.target.empty()) {
    into = std::move(r);
    return;
  }
  into.requests += r.requests;
  into.errors += r.errors;
  into.seconds += r.seconds;
  into.server_cpu_s += r.server_cpu_s;
  into.latency_ms.insert(into.latency_ms.end(), r.latency_ms.begin(), r.latency_ms.end());
}

struct Options {
  std::string goniod, connect, token, token_file;
  std::size_t clients = 64;
  double seconds = 5, time_scale = 1;
  int rounds = 3;  // the baselines and system.info alternate this many times
  bool as_json = false, hostile = false, throughput = false, tls = false;
  std::optional<double> client_share;  // server.client_share_busy of the goniod it starts
  std::optional<int> io_threads;       // server.io_threads of the goniod it starts
};

// goniod --mock in a fresh state directory with a TCP listener (--tls: a TLS one, with a
// self-signed certificate that openssl makes there, which the clients then trust as their
// CA), stopped and removed at the end.
class Goniod {
 public:
  Goniod(std::string exe, double time_scale, std::optional<double> client_share, std::optional<int> io_threads,
         bool tls) {
    std::string tmpl = (fs::temp_directory_path() / "gonio-load-XXXXXX").string();
    if (!::mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp failed");
    dir_ = tmpl;
    if (exe.empty()) exe = (fs::read_symlink("/proc/self/exe").parent_path() / "goniod").string();
    const auto cert = dir_ / "tls.pem", key = dir_ / "tls.key";
    if (tls) {
      const auto cmd = fmt::format("openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -days 1 "
                                   "-subj /CN=127.0.0.1 -addext subjectAltName=IP:127.0.0.1 -keyout '{}' -out '{}' "
                                   ">/dev/null 2>&1", key.string(), cert.string());
      if (std::system(cmd.c_str()) != 0) throw std::runtime_error("--tls: openssl could not make a certificate");
      fs::permissions(key, fs::perms::owner_read | fs::perms::owner_write);
      g_ca = cert.string();
    }
    const std::string scheme = tls ? "tls://" : "tcp://";
    {
      std::ofstream cfg(dir_ / "load.toml");
      cfg << "[server]\nlog_level = \"warn\"\nlisten = [\"" << scheme << "127.0.0.1:0\"]\n"
          << (client_share ? fmt::format("client_share_busy = {}\n", *client_share) : std::string())
          << (io_threads ? fmt::format("io_threads = {}\n", *io_threads) : std::string())
          << "max_connections = 4096\n\n[instrument.motion]\ndriver = \"mock\"\n"
          << fmt::format("sample = \"{}\"\ntime_scale = {}\n\n", gonio::daemon::kDemoSampleBsdf, time_scale)
          << "[instrument.photometer]\ndriver = \"mock\"\n"
          << (tls ? fmt::format("\n[server.tls]\ncert = \"{}\"\nkey = \"{}\"\n", cert.string(), key.string()) : "");
    }
    pid_ = ::fork();
    if (pid_ == 0) {
      const int fd = ::open((dir_ / "goniod.log").c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0640);
      if (fd >= 0) ::dup2(fd, STDERR_FILENO), ::dup2(fd, STDOUT_FILENO);
      const auto state = dir_.string(), cfg = (dir_ / "load.toml").string();
      ::execl(exe.c_str(), exe.c_str(), "--state-dir", state.c_str(), "--config", cfg.c_str(), "--mock",
              static_cast<char*>(nullptr));
      ::_exit(127);
    }
    for (int i = 0; i < 300 && uri_.empty(); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      std::ifstream in(dir_ / "endpoints.json");
      const auto ep = json::parse(in, nullptr, false);
      if (ep.is_object())
        for (const auto& l : ep["listen"])
          if (l.get<std::string>().starts_with(scheme)) uri_ = l.get<std::string>();
    }
    if (uri_.empty()) {
      ::kill(pid_, SIGTERM);  // the state directory stays, for its log
      ::waitpid(pid_, nullptr, 0);
      throw std::runtime_error("goniod did not start; see " + (dir_ / "goniod.log").string());
    }
    std::ifstream tok(dir_ / "admin.token");
    std::getline(tok, token_);
  }
  ~Goniod() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      ::waitpid(pid_, nullptr, 0);
    }
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  Goniod(const Goniod&) = delete;
  Goniod& operator=(const Goniod&) = delete;

  const std::string& uri() const { return uri_; }
  const std::string& token() const { return token_; }
  pid_t pid() const { return pid_; }

 private:
  fs::path dir_;
  pid_t pid_ = -1;
  std::string uri_, token_;
};

// A sample and a scan long enough to outlast every phase, running with points to page
// through (with --throughput, at time scale 0).
std::int64_t start_scan(Client& admin, bool throughput) {
  if (admin.call("sample.list").empty())
    admin.call("sample.create", json{{"name", "load"}, {"bsdf", gonio::daemon::kDemoSampleBsdf}});
  const auto s = admin.call("scan.submit", json{{"sample", "load"},
                                               {"grids", {throughput ? "in=15,30,45,60;out=-5:80:0.5" : "in=15,30,45,60;out=-5:80:1"}},
                                               {"repeats", throughput ? 100 : 2}});
  const auto scan = s["id"].get<std::int64_t>();
  for (int i = 0; i < 600; ++i) {
    const auto sc = admin.call("scan.get", json{{"scan", scan}});
    if (sc["points_done"].get<std::size_t>() >= 10) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return scan;
}

// The runner's throughput: points per second of the running scan with no client, and with
// the clients split between system.info and scan.points, in four alternating rounds of each
// (a scan's points differ in cost along the scan: alternating compares like with like). The
// first and last idle rounds are reported too (their difference says how steady it was).
json measure_throughput(Client& admin, const Options& o, const std::string& uri, const std::string& token,
                        std::int64_t first, std::vector<Result>& results) {
  // A scan of its own, so that the phases before have not used it up.
  if (admin.call("scan.get", json{{"scan", first}})["state"] == "running") admin.call("scan.cancel", json{{"scan", first}});
  const auto scan = start_scan(admin, true);
  constexpr int kRounds = 4;
  const double round_s = o.seconds / kRounds;
  const auto done = [&] { return admin.call("scan.get", json{{"scan", scan}})["points_done"].get<double>(); };
  double idle_points = 0, idle_s = 0, loaded_points = 0, loaded_s = 0, idle_first = 0, idle_last = 0;
  Result all;
  all.target = "system.info + scan.points";
  all.clients = o.clients;
  json governor;
  for (int round = 0; round < kRounds; ++round) {
    double a = done();
    auto t0 = Clock::now();
    std::this_thread::sleep_for(std::chrono::duration<double>(round_s));
    const double secs = std::chrono::duration<double>(Clock::now() - t0).count();
    const double pts = done() - a;
    idle_points += pts;
    idle_s += secs;
    (round == 0 ? idle_first : idle_last) = pts / secs;
    a = done();
    auto r = run_clients("system.info + scan.points", uri, token, o.clients, round_s,
                         {{"system.info", json::object()},
                          {"scan.points", json{{"scan", scan}, {"offset", 0}, {"limit", 10}}}});
    loaded_points += done() - a;
    loaded_s += r.seconds;
    if (round == kRounds - 1) governor = admin.call("system.info")["governor"];
    pool(all, std::move(r));
  }
  std::sort(all.latency_ms.begin(), all.latency_ms.end());
  results.push_back(std::move(all));
  const auto state = admin.call("scan.get", json{{"scan", scan}})["state"].get<std::string>();
  if (state != "running")
    throw std::runtime_error("the scan ended (" + state + ") before the throughput was measured: lower --seconds");
  const double idle = idle_points / idle_s, loaded = loaded_points / loaded_s;
  return json{{"idle_points_per_s", idle}, {"idle_first", idle_first}, {"idle_last", idle_last},
              {"loaded_points_per_s", loaded}, {"loaded_over_idle", idle > 0 ? loaded / idle : 0},
              {"governor", governor}};
}

// scan.pause of a queued scan while 32 viewers hammer scan.export: its latency.
json measure_control(Client& admin, const std::string& uri, const std::string& token, std::int64_t scan,
                     double seconds) {
  const auto viewer_token = admin.call("auth.create_token", json{{"name", "load-viewer"}, {"role", "viewer"}})["token"].get<std::string>();
  const auto queued = admin.call("scan.submit", json{{"sample", "load"}, {"geometries", {"45as15"}},
                                                      {"not_before", "2999-01-01T00:00:00Z"}})["id"];
  std::atomic<bool> stop{false};
  std::atomic<std::size_t> exports{0};
  std::vector<std::thread> viewers;
  // The viewers stop and are joined however this ends: a technician's call that times out
  // throws, and a joinable thread destroyed would end the tool without saying why.
  struct Joiner {
    std::atomic<bool>& stop;
    std::vector<std::thread>& ts;
    ~Joiner() {
      stop = true;
      for (auto& t : ts)
        if (t.joinable()) t.join();
    }
  } joiner{stop, viewers};
  for (int i = 0; i < 32; ++i)
    viewers.emplace_back([&] {
      try {
        Client v(uri, std::chrono::seconds(60));
        v.login(viewer_token);
        while (!stop.load()) {
          v.call("scan.export", json{{"scan", scan}, {"format", "csv"}});
          ++exports;
        }
      } catch (const std::exception&) {
      }
    });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  std::vector<double> pause_ms;
  {
    Client tech(uri, std::chrono::seconds(60));
    tech.login(token);
    const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
    while (Clock::now() < end) {
      const auto t0 = Clock::now();
      tech.call("scan.pause", json{{"scan", queued}});
      pause_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      tech.call("scan.resume", json{{"scan", queued}});
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  stop = true;
  for (auto& t : viewers) t.join();
  viewers.clear();
  return json{{"viewers", 32}, {"exports", exports.load()}, {"pauses", pause_ms.size()},
              {"pause_p50_ms", quantile(pause_ms, 0.5)},
              {"pause_p99_ms", quantile(pause_ms, 0.99)},
              {"pause_max_ms", pause_ms.empty() ? NAN : pause_ms.back()}};
}

// The hostile phases (see the top of the file), goniod's peak RSS after each.
json measure_hostile(Client& admin, const Goniod& g, std::int64_t scan, double seconds) {
  json out = json::object();
  Hostile h{g.uri(), g.token(), scan};
  json single = json::array();
  out["peak_reset"] = reset_peak_rss(g.pid());
  out["single_start_rss_mib"] = rss_mib(g.pid());
  for (int kind = 0; kind <= 5; ++kind) {
    h.act(kind);
    single.push_back(json{{"kind", kind}, {"peak_rss_mib", peak_rss_mib(g.pid())}});
  }
  out["single_peak_rss_mib"] = peak_rss_mib(g.pid());
  std::atomic<std::size_t> acts{0};
  out["peak_reset"] = reset_peak_rss(g.pid()) && out["peak_reset"].get<bool>();
  out["flood_start_rss_mib"] = rss_mib(g.pid());
  {
    std::vector<std::thread> ts;
    const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
    for (int i = 0; i < 64; ++i)
      ts.emplace_back([&, i] {
        for (int n = 0; Clock::now() < end; ++n) {
          try {
            h.act((i + n) % 9);
            ++acts;
          } catch (const std::exception&) {
          }
        }
      });
    for (auto& t : ts) t.join();
  }
  out["flood_clients"] = 64;
  out["flood_acts"] = acts.load();
  out["flood_peak_rss_mib"] = peak_rss_mib(g.pid());
  out["control"] = measure_control(admin, g.uri(), g.token(), scan, seconds);
  out["peak_rss_mib"] = peak_rss_mib(g.pid());
  out["single"] = single;
  // What the flood left behind (batches of peers long gone) is worked off or skipped: the
  // time until no batch answer is being assembled any more.
  const auto drain_start = Clock::now();
  json info = admin.call("system.info");
  while (info["rpc"].value("building_bytes", 0) > 0 && Clock::now() - drain_start < std::chrono::seconds(60)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
    info = admin.call("system.info");
  }
  out["drain_s"] = info["rpc"].value("building_bytes", 0) > 0
                       ? json(nullptr)
                       : json(std::chrono::duration<double>(Clock::now() - drain_start).count());
  out["net"] = info["net"];
  out["rpc"] = info["rpc"];
  return out;
}

struct Report {
  std::vector<Result> results;
  json before, after, scan, throughput = nullptr, hostile = json::object();
  json connect;  // measure_connect
  std::int64_t scan_id = 0;
};

void print(const Report& rep, const Options& o) {
  json out = json::array();
  gonio::daemon::Table t(
      {"target", "clients", "requests", "req/s", "p50 ms", "p99 ms", "max ms", "errors", "server µs/req"});
  for (auto r : rep.results) {
    const double p50 = quantile(r.latency_ms, 0.5), p99 = quantile(r.latency_ms, 0.99);
    const double mx = r.latency_ms.empty() ? NAN : r.latency_ms.back();
    const double rps = static_cast<double>(r.requests) / r.seconds;
    const double server_us = 1e6 * r.server_cpu_s / static_cast<double>(r.requests);
    t.add({r.target, std::to_string(r.clients), std::to_string(r.requests), fmt::format("{:.0f}", rps),
           fmt::format("{:.3f}", p50), fmt::format("{:.3f}", p99), fmt::format("{:.3f}", mx),
           std::to_string(r.errors), std::isfinite(server_us) ? fmt::format("{:.1f}", server_us) : "-"});
    out.push_back(json{{"target", r.target}, {"clients", r.clients}, {"requests", r.requests},
                       {"throughput_rps", rps}, {"p50_ms", p50}, {"p99_ms", p99}, {"max_ms", mx},
                       {"errors", r.errors}, {"server_cpu_us_per_request", server_us}});
  }
  // Each target against echo, as the speed targets are set: req/s ≥ 50 %, p50 ≤ 2×, p99 ≤ 1.3×.
  json vs_echo = json::object();
  std::string ratios;
  if (!out.empty() && out[0]["target"] == "echo (baseline)") {
    const auto& e = out[0];
    for (std::size_t i = 1; i < out.size(); ++i) {
      const auto& r = out[i];
      // Only the targets measured in rounds beside echo, calling what echo is called with.
      if (r["target"] != "replay (system.info's bytes)" && r["target"] != "system.info") continue;
      const double tp = r["throughput_rps"].get<double>() / e["throughput_rps"].get<double>();
      const double p50 = r["p50_ms"].get<double>() / e["p50_ms"].get<double>();
      const double p99 = r["p99_ms"].get<double>() / e["p99_ms"].get<double>();
      vs_echo[r["target"].get<std::string>()] = json{{"throughput", tp}, {"p50", p50}, {"p99", p99}};
      ratios += fmt::format("{} ÷ echo: req/s {:.0f} %, p50 {:.2f}×, p99 {:.2f}×\n", r["target"].get<std::string>(),
                            100 * tp, p50, p99);
    }
  }
  const auto& runner = rep.after["runner"];
  const double rss_mib = rep.after["rss_bytes"].get<double>() / (1024.0 * 1024.0);
  const auto points_during = runner["points_measured"].get<std::int64_t>() -
                             rep.before["runner"]["points_measured"].get<std::int64_t>();
  if (o.as_json) {
    std::cout << json{{"results", out},           {"vs_echo", vs_echo}, {"goniod_rss_mib", rss_mib},
                      {"runner", runner},         {"scan", rep.scan},
                      {"points_during_run", points_during}, {"hostile", rep.hostile},
                      {"throughput", rep.throughput}, {"connect", rep.connect}}
                     .dump(2)
              << "\n";
    return;
  }
  std::cout << t.render() << ratios;
  std::cout << fmt::format("connect: a new connection and auth.login p50 {:.3f} ms, its first system.info p50 {:.3f} ms "
                           "({} connections, one at a time); goniod's CPU per connection {} ms\n",
                           rep.connect["connect_login_p50_ms"].get<double>(), rep.connect["first_call_p50_ms"].get<double>(),
                           rep.connect["connections"].get<int>(),
                           gonio::daemon::cell(rep.connect["server_cpu_ms_per_connection"]));
  std::cout << fmt::format(
      "goniod: rss {:.1f} MiB; scan {} {} with {} points measured during the run; runner's own time "
      "per point p50 {} ms, p99 {} ms, max {} ms (last {} points)\n",
      rss_mib, rep.scan_id, rep.scan.is_null() ? "-" : gonio::daemon::cell(rep.scan["state"]), points_during,
      gonio::daemon::cell(runner["overhead_ms_p50"]), gonio::daemon::cell(runner["overhead_ms_p99"]),
      gonio::daemon::cell(runner["overhead_ms_max"]), gonio::daemon::cell(runner["overhead_window"]));
  if (const auto& tp = rep.throughput; !tp.is_null())
    std::cout << fmt::format(
        "throughput: the scan measured {:.1f} points/s idle (first round {:.1f}, last {:.1f}) and {:.1f} "
        "under {} clients: {:.0f} % of idle; governor {}\n",
        tp["idle_points_per_s"].get<double>(), tp["idle_first"].get<double>(), tp["idle_last"].get<double>(),
        tp["loaded_points_per_s"].get<double>(), o.clients, 100 * tp["loaded_over_idle"].get<double>(),
        tp["governor"].dump());
  if (const auto& h = rep.hostile; !h.empty()) {
    const auto& ctl = h["control"];
    std::cout << fmt::format(
        "hostile: goniod peak RSS {:.1f} MiB in single requests (from {:.1f}), {:.1f} MiB in {} clients "
        "({} acts, from {:.1f}){}; scan.pause under {} export viewers ({} exports): p50 {:.2f} ms, p99 {:.2f} ms, "
        "max {:.2f} ms ({} pauses); batches assembled for the flood drained {}; net {}; rpc {}\n",
        h["single_peak_rss_mib"].get<double>(), h["single_start_rss_mib"].get<double>(),
        h["flood_peak_rss_mib"].get<double>(), h["flood_clients"].get<int>(), h["flood_acts"].get<std::size_t>(),
        h["flood_start_rss_mib"].get<double>(),
        h["peak_reset"].get<bool>() ? "" : " (peaks not reset: the kernel refused; each covers goniod's life)", ctl["viewers"].get<int>(), ctl["exports"].get<std::size_t>(),
        ctl["pause_p50_ms"].get<double>(), ctl["pause_p99_ms"].get<double>(), ctl["pause_max_ms"].get<double>(),
        ctl["pauses"].get<std::size_t>(),
        h["drain_s"].is_null() ? std::string("NOT within 60 s") : fmt::format("{:.1f} s after", h["drain_s"].get<double>()),
        h["net"].dump(), h["rpc"].dump());
  }
}

// A new connection's cost, one at a time: connect (and the TLS handshake on tls://) and
// auth.login, then one system.info; each phase's median over kConnects connections, and
// the server's CPU per connection (`cpu`: its CPU seconds so far; NAN when not known).
json measure_connect(const std::string& uri, const std::string& token, const std::function<double()>& cpu) {
  constexpr int kConnects = 200;
  std::vector<double> setup, first;
  const double cpu0 = cpu();
  for (int i = 0; i < kConnects; ++i) {
    const auto t0 = Clock::now();
    Client c(uri, std::chrono::seconds(10), g_ca);
    if (!token.empty()) c.login(token);
    const auto t1 = Clock::now();
    c.call_checked("system.info");
    setup.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    first.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t1).count());
  }
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const double server_ms = 1000 * (cpu() - cpu0) / kConnects;
  return {{"connections", kConnects}, {"connect_login_p50_ms", median(setup)}, {"first_call_p50_ms", median(first)},
          {"server_cpu_ms_per_connection", std::isfinite(server_ms) ? json(server_ms) : json(nullptr)}};
}

// Every target against goniod (its own, or the one at --connect), the echo baseline first.
void run(Options o) {
  std::optional<Goniod> own;
  std::string uri = o.connect, token = o.token;
  if (uri.empty()) {
    own.emplace(o.goniod, o.time_scale, o.client_share, o.io_threads, o.tls);
    uri = own->uri();
    token = own->token();
  } else if (token.empty() && !o.token_file.empty()) {
    std::ifstream tok(o.token_file);
    std::getline(tok, token);
  }
  Client admin(uri, std::chrono::seconds(30), g_ca);
  if (!token.empty()) admin.login(token);
  Report rep;
  rep.connect = measure_connect(uri, token, [&] { return own ? process_cpu_seconds(own->pid()) : NAN; });
  if (own) {
    rep.scan_id = start_scan(admin, false);
  } else {
    const auto list = admin.call("scan.list", json{{"limit", 1}});
    if (!list.empty()) rep.scan_id = list[0]["id"].get<std::int64_t>();
  }
  // The baselines and system.info are measured in --rounds alternating rounds and pooled,
  // so that the machine's drift over a run (other tenants of a VM) falls on all three alike.
  EchoServer echo, replay(admin.call("system.info").dump());
  // goniod's CPU with no client (the running scan's), taken off its CPU under the clients.
  double idle_rate = NAN;
  if (own) {
    const double c0 = process_cpu_seconds(own->pid());
    const auto t0 = Clock::now();
    std::this_thread::sleep_for(std::chrono::seconds(1));
    idle_rate = (process_cpu_seconds(own->pid()) - c0) / std::chrono::duration<double>(Clock::now() - t0).count();
  }
  const auto measure = [&](const std::string& target, const std::string& at, const std::string& tok,
                           const Calls& calls, double seconds, const std::function<double()>& cpu,
                           double cpu_idle_rate) {
    const double c0 = cpu();
    auto r = run_clients(target, at, tok, o.clients, seconds, calls);
    r.server_cpu_s = cpu() - c0 - cpu_idle_rate * r.seconds;
    return r;
  };
  const auto goniod_cpu = [&] { return own ? process_cpu_seconds(own->pid()) : NAN; };
  const Calls info{{"system.info", json::object()}};
  rep.before = admin.call("system.info");
  std::vector<Result> pooled(3);
  for (int round = 0; round < o.rounds; ++round) {
    const double s = o.seconds / o.rounds;
    pool(pooled[0], measure("echo (baseline)", echo.uri(), "", info, s, [&] { return echo.cpu_seconds(); }, 0));
    pool(pooled[1], measure("replay (system.info's bytes)", replay.uri(), "", info, s,
                            [&] { return replay.cpu_seconds(); }, 0));
    pool(pooled[2], measure("system.info", uri, token, info, s, goniod_cpu, idle_rate));
  }
  rep.results = std::move(pooled);
  if (rep.scan_id)
    rep.results.push_back(measure("scan.points", uri, token,
                                  {{"scan.points", json{{"scan", rep.scan_id}, {"offset", 0}, {"limit", 10}}}},
                                  o.seconds, goniod_cpu, idle_rate));
  if (o.throughput && rep.scan_id) rep.throughput = measure_throughput(admin, o, uri, token, rep.scan_id, rep.results);
  rep.after = admin.call("system.info");
  rep.scan = rep.scan_id ? admin.call("scan.get", json{{"scan", rep.scan_id}}) : json(nullptr);
  if (o.hostile && own && rep.scan_id) rep.hostile = measure_hostile(admin, *own, rep.scan_id, o.seconds);
  print(rep, o);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"gonio-load — goniod latency and throughput beside a loopback echo baseline"};
  Options o;
  app.add_option("--goniod", o.goniod, "goniod to start (default: next to gonio-load)");
  app.add_option("--connect", o.connect, "measure a running goniod at tcp://HOST:PORT or tls://HOST:PORT instead");
  app.add_option("--ca", g_ca, "with --connect tls://: the CA file of goniod's certificate");
  app.add_flag("--tls", o.tls, "the goniod it starts listens on tls:// (a self-signed certificate) and the clients use it");
  app.add_option("--token", o.token, "bearer token for --connect");
  app.add_option("--token-file", o.token_file, "file with the token for --connect");
  app.add_option("--clients", o.clients, "concurrent clients")->check(CLI::Range(1, 1024));
  app.add_option("--seconds", o.seconds, "duration of each target")->check(CLI::Range(0.2, 3600.0));
  app.add_option("--rounds", o.rounds,
                 "measure the baselines and system.info in this many alternating rounds of "
                 "seconds/rounds each, pooled")
      ->check(CLI::Range(1, 100));
  app.add_option("--time-scale", o.time_scale, "the mock's real-time factor (keeps the scan running)");
  app.add_flag("--json", o.as_json, "print the figures as JSON");
  app.add_option("--client-share", o.client_share,
                 "server.client_share_busy of the goniod it starts (0: no client governor)")
      ->check(CLI::Range(0.0, 64.0));
  app.add_option("--io-threads", o.io_threads, "server.io_threads of the goniod it starts")
      ->check(CLI::Range(1, 64));
  app.add_option("--client-nice", g_client_nice,
                 "run the client threads this much nicer (0–19): clients on another machine take "
                 "no CPU from goniod")
      ->check(CLI::Range(0, 19));
  app.add_flag("--parse-replies", g_parse_replies,
               "parse every answer whole, as gonioctl does (default: check its id and error only)");
  app.add_flag("--throughput", o.throughput,
               "also measure the scan's points per second idle and under the clients (a long scan "
               "on the mock at time scale 0)");
  app.add_flag("--hostile", o.hostile, "also measure goniod under hostile clients (peak RSS, control latency under an export flood)");
  CLI11_PARSE(app, argc, argv);
  if (o.throughput) {
    if (!o.connect.empty()) {
      std::cerr << "gonio-load: --throughput starts its own goniod (not with --connect)\n";
      return 2;
    }
    o.time_scale = 0;
  }
  try {
    run(o);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "gonio-load: " << e.what() << "\n";
    return 1;
  }
}
