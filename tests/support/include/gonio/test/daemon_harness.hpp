// Test harness for goniod: real processes in temporary state dirs, real sockets (Unix,
// TCP loopback, HTTP, WebSocket), written against the wire protocol only.
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <spawn.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "gonio/test/command.hpp"

namespace gonio::test {

namespace fs = std::filesystem;
using nlohmann::json;
using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

// The mock lab's hidden true sample in these tests, and a catalog BSDF that agrees with it.
inline constexpr const char* kTrueSample = "lambert:albedo=0.6";

struct TempDir {
  fs::path path;
  TempDir() {
    std::string tmpl = (fs::temp_directory_path() / "gonio-itest-XXXXXX").string();
    if (!::mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp failed");
    path = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
};

// Waits until `pred` holds, polling; false on timeout.
inline bool eventually(const std::function<bool()>& pred, std::chrono::milliseconds timeout = 15s) {
  const auto end = Clock::now() + timeout;
  while (Clock::now() < end) {
    if (pred()) return true;
    std::this_thread::sleep_for(20ms);
  }
  return pred();
}

// ---- sockets -----------------------------------------------------------------------------

inline int connect_unix(const std::string& path) {
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::strncpy(a.sun_path, path.c_str(), sizeof a.sun_path - 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    throw std::runtime_error("connect " + path + ": " + std::strerror(errno));
  }
  return fd;
}

inline int connect_tcp(const std::string& host, int port) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  ::inet_pton(AF_INET, host.c_str(), &a.sin_addr);
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    throw std::runtime_error("connect tcp: " + std::string(std::strerror(errno)));
  }
  int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  return fd;
}

// "tcp://127.0.0.1:4321" → port
// What a program of the build printed (stdout and stderr together) and its exit status.
using ProgramRun = CommandRun;

// Runs `program` (a file of the build's bin directory) with `args`, each quoted for the shell.
inline ProgramRun run_program(const std::string& program, const std::vector<std::string>& args) {
  std::string cmd = std::string(GONIO_BIN_DIR) + "/" + program;
  for (const auto& a : args) {
    cmd += " '";
    for (char ch : a) cmd += ch == '\'' ? std::string("'\\''") : std::string(1, ch);
    cmd += "'";
  }
  return run_command(cmd + " 2>&1");
}

inline int port_of(const std::string& uri) { return std::stoi(uri.substr(uri.rfind(':') + 1)); }

class Conn {
 public:
  explicit Conn(int fd) : fd_(fd) {}
  ~Conn() {
    if (fd_ >= 0) ::close(fd_);
  }
  Conn(Conn&& o) noexcept : fd_(o.fd_), buf_(std::move(o.buf_)), notes_(std::move(o.notes_)), next_id_(o.next_id_) { o.fd_ = -1; }
  Conn(const Conn&) = delete;
  Conn& operator=(const Conn&) = delete;
  int fd() const { return fd_; }

  void send_raw(const std::string& bytes) {
    std::size_t off = 0;
    while (off < bytes.size()) {
      const auto n = ::send(fd_, bytes.data() + off, bytes.size() - off, MSG_NOSIGNAL);
      if (n <= 0) throw std::runtime_error("send failed");
      off += static_cast<std::size_t>(n);
    }
  }
  // Bytes until the peer closes or `timeout` passes.
  bool closed_by_peer(std::chrono::milliseconds timeout) {
    const auto end = Clock::now() + timeout;
    for (;;) {
      pollfd p{fd_, POLLIN, 0};
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count();
      if (left <= 0) return false;
      if (::poll(&p, 1, static_cast<int>(left)) <= 0) continue;
      char b[4096];
      const auto n = ::recv(fd_, b, sizeof b, 0);
      if (n <= 0) return true;
      buf_.append(b, static_cast<std::size_t>(n));
    }
  }
  std::optional<std::string> line(std::chrono::milliseconds timeout = 10s) {
    const auto end = Clock::now() + timeout;
    for (;;) {
      if (const auto nl = buf_.find('\n'); nl != std::string::npos) {
        auto l = buf_.substr(0, nl);
        buf_.erase(0, nl + 1);
        return l;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count();
      if (left <= 0) return std::nullopt;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left)) <= 0) continue;
      char b[65536];
      const auto n = ::recv(fd_, b, sizeof b, 0);
      if (n <= 0) return std::nullopt;
      buf_.append(b, static_cast<std::size_t>(n));
    }
  }
  // The full response object to a request (notifications are kept for notification()).
  json request(const std::string& method, const json& params = json::object(), std::chrono::milliseconds timeout = 20s) {
    const auto id = next_id_++;
    send_raw(json{{"jsonrpc", "2.0"}, {"id", id}, {"method", method}, {"params", params}}.dump() + "\n");
    return response_to(id, timeout);
  }
  json response_to(const json& id, std::chrono::milliseconds timeout = 20s) {
    const auto end = Clock::now() + timeout;
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now());
      const auto l = line(std::max(left, 1ms));
      if (!l) throw std::runtime_error("no response");
      auto j = json::parse(*l);
      if (j.is_object() && !j.contains("id")) {
        notes_.push_back(std::move(j));
        continue;
      }
      if (j.is_array() || j["id"] == id || j["id"].is_null()) return j;
    }
  }
  // The result, or throws with the error.
  json call(const std::string& method, const json& params = json::object()) {
    const auto r = request(method, params);
    if (r.contains("error")) throw std::runtime_error(method + ": " + r["error"].dump());
    return r["result"];
  }
  std::optional<json> notification(std::chrono::milliseconds timeout = 10s) {
    if (!notes_.empty()) {
      auto n = std::move(notes_.front());
      notes_.pop_front();
      return n;
    }
    const auto end = Clock::now() + timeout;
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now());
      if (left <= 0ms) return std::nullopt;
      const auto l = line(left);
      if (!l) return std::nullopt;
      auto j = json::parse(*l);
      if (!j.contains("id")) return j;
    }
  }

 private:
  int fd_;
  std::string buf_;
  std::deque<json> notes_;
  long long next_id_ = 1;
};

// ---- HTTP and WebSocket ------------------------------------------------------------------

struct HttpResponse {
  int status = 0;
  std::string headers, body;
};

// One HTTP/1.1 request on a fresh connection (Connection: close).
inline HttpResponse http(int port, const std::string& method, const std::string& target, const std::string& body,
                         const std::string& token = {}) {
  Conn c(connect_tcp("127.0.0.1", port));
  std::string req = method + " " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n";
  if (!token.empty()) req += "Authorization: Bearer " + token + "\r\n";
  req += "Content-Type: application/json\r\nContent-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
  c.send_raw(req);
  std::string all;
  for (;;) {
    pollfd p{c.fd(), POLLIN, 0};
    if (::poll(&p, 1, 10000) <= 0) break;
    char b[65536];
    const auto n = ::recv(c.fd(), b, sizeof b, 0);
    if (n <= 0) break;
    all.append(b, static_cast<std::size_t>(n));
  }
  HttpResponse r;
  const auto end = all.find("\r\n\r\n");
  if (end == std::string::npos || all.size() < 12) return r;
  r.status = std::stoi(all.substr(9, 3));
  r.headers = all.substr(0, end);
  r.body = all.substr(end + 4);
  return r;
}

// A minimal WebSocket client (RFC 6455): text frames, masked, payloads < 2^63.
class WebSocket {
 public:
  WebSocket(int port, const std::string& token = {}) : c_(connect_tcp("127.0.0.1", port)) {
    std::string req = "GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                      "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n";
    if (!token.empty()) req += "Authorization: Bearer " + token + "\r\n";
    c_.send_raw(req + "\r\n");
    std::string head;
    while (head.find("\r\n\r\n") == std::string::npos) {
      char ch;
      if (::recv(c_.fd(), &ch, 1, 0) != 1) throw std::runtime_error("ws handshake failed");
      head += ch;
    }
    status = std::stoi(head.substr(9, 3));
  }
  int status = 0;

  void send_text(const std::string& text) { send_frame(0x1, text); }
  // A Close frame with `code`, as a browser answers the server's.
  void send_close(int code) {
    send_frame(0x8, std::string{static_cast<char>(code >> 8), static_cast<char>(code & 0xff)});
  }
  // The status code of the Close frame goniod sent, once read_text met it.
  std::optional<int> close_code;
  // After the closing handshake: whether the TCP connection ends with an orderly FIN within
  // `timeout` (recv returns 0), not a reset (ECONNRESET), which a browser reports as an error.
  bool ends_cleanly(std::chrono::milliseconds timeout = 10s) {
    const auto end = Clock::now() + timeout;
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count();
      if (left <= 0) return false;
      pollfd p{c_.fd(), POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left)) <= 0) continue;
      char b[4096];
      const auto r = ::recv(c_.fd(), b, sizeof b, 0);
      if (r == 0) return true;
      if (r < 0) return false;
    }
  }

  void send_frame(int opcode, const std::string& text) {
    std::string f;
    f += static_cast<char>(0x80 | opcode);
    const std::size_t n = text.size();
    if (n < 126) f += static_cast<char>(0x80 | n);
    else if (n < 65536) {
      f += static_cast<char>(0x80 | 126);
      f += static_cast<char>(n >> 8), f += static_cast<char>(n & 0xff);
    } else {
      f += static_cast<char>(0x80 | 127);
      for (int i = 7; i >= 0; --i) f += static_cast<char>((static_cast<std::uint64_t>(n) >> (8 * i)) & 0xff);
    }
    const unsigned char mask[4] = {0x12, 0x34, 0x56, 0x78};
    for (unsigned char m : mask) f += static_cast<char>(m);
    for (std::size_t i = 0; i < n; ++i) f += static_cast<char>(text[i] ^ static_cast<char>(mask[i % 4]));
    c_.send_raw(f);
  }
  // The next text message; nullopt on timeout or close.
  std::optional<std::string> read_text(std::chrono::milliseconds timeout = 10s) {
    for (;;) {
      std::string h;
      if (!read_exact(2, h, timeout)) return std::nullopt;
      const int op = static_cast<unsigned char>(h[0]) & 0x0f;
      std::uint64_t n = static_cast<unsigned char>(h[1]) & 0x7f;
      std::string ext;
      if (n == 126) {
        if (!read_exact(2, ext, timeout)) return std::nullopt;
        n = (static_cast<std::uint64_t>(static_cast<unsigned char>(ext[0])) << 8) | static_cast<unsigned char>(ext[1]);
      } else if (n == 127) {
        if (!read_exact(8, ext, timeout)) return std::nullopt;
        n = 0;
        for (char ch : ext) n = (n << 8) | static_cast<unsigned char>(ch);
      }
      std::string payload;
      if (!read_exact(static_cast<std::size_t>(n), payload, timeout)) return std::nullopt;
      if (op == 0x1) return payload;
      if (op == 0x8) {  // Close: its status code (RFC 6455 §5.5.1), 1005 when it has none
        close_code = payload.size() >= 2
                         ? (static_cast<unsigned char>(payload[0]) << 8) | static_cast<unsigned char>(payload[1])
                         : 1005;
        return std::nullopt;
      }
      // pings, pongs: ignore
    }
  }
  json call(const std::string& method, const json& params = json::object()) {
    const auto id = next_id_++;
    send_text(json{{"jsonrpc", "2.0"}, {"id", id}, {"method", method}, {"params", params}}.dump());
    for (;;) {
      const auto t = read_text();
      if (!t) throw std::runtime_error("ws: no response");
      auto j = json::parse(*t);
      if (!j.contains("id")) {
        notes.push_back(std::move(j));
        continue;
      }
      if (j["id"] == id) return j;
    }
  }
  std::deque<json> notes;
  Conn& conn() { return c_; }
  // Whether goniod closed the connection (a close frame or EOF) within `timeout`.
  bool closed_by_peer(std::chrono::milliseconds timeout = 10s) {
    return !read_text(timeout).has_value() && c_.closed_by_peer(2s);
  }

 private:
  bool read_exact(std::size_t n, std::string& out, std::chrono::milliseconds timeout) {
    out.clear();
    const auto end = Clock::now() + timeout;
    while (out.size() < n) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count();
      if (left <= 0) return false;
      pollfd p{c_.fd(), POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left)) <= 0) continue;
      std::string b(n - out.size(), '\0');
      const auto r = ::recv(c_.fd(), b.data(), b.size(), 0);
      if (r <= 0) return false;
      out.append(b.data(), static_cast<std::size_t>(r));
    }
    return true;
  }
  Conn c_;
  long long next_id_ = 1;
};

// ---- goniod ------------------------------------------------------------------------------

struct MockOptions {
  std::string true_sample = kTrueSample;
  double time_scale = 0;
  std::string faults;          // TOML inline table body, e.g. "garbage_at_point = 3"
  std::string lab;             // more keys of the mock lab ([instrument.motion])
  std::string extra;           // more TOML appended
  bool tcp = true, http = true;
};

inline std::string mock_config(const MockOptions& o) {
  std::ostringstream s;
  s << "[server]\nlog_level = \"debug\"\nread_timeout_s = 1\nlisten = [";
  if (o.tcp) s << "\"tcp://127.0.0.1:0\"";
  if (o.tcp && o.http) s << ", ";
  if (o.http) s << "\"http://127.0.0.1:0\"";
  s << "]\n\n[instrument.motion]\ndriver = \"mock\"\nsample = \"" << o.true_sample << "\"\ntime_scale = " << o.time_scale << "\n";
  if (!o.faults.empty()) s << "faults = { " << o.faults << " }\n";
  s << o.lab;
  s << "\n[instrument.photometer]\ndriver = \"mock\"\n\n[twin]\nthreads = 1\nrel_se = 0.01\nreplicates = 8\n\n" << o.extra;
  return s.str();
}

class Goniod {
 public:
  Goniod(const fs::path& state, const std::string& config_text, std::vector<std::string> env = {})
      : state_(state), env_(std::move(env)) {
    fs::create_directories(state);
    std::ofstream(state / "test.toml") << config_text;
    start();
  }
  ~Goniod() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  Goniod(const Goniod&) = delete;
  Goniod& operator=(const Goniod&) = delete;

  void start() {
    const auto log = (state_ / "goniod.log").string();
    std::error_code ec;
    fs::remove(state_ / "endpoints.json", ec);
    pid_ = ::fork();
    if (pid_ == 0) {
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0640);
      ::dup2(fd, 1), ::dup2(fd, 2);
      for (const auto& kv : env_) {
        const auto eq = kv.find('=');
        ::setenv(kv.substr(0, eq).c_str(), kv.substr(eq + 1).c_str(), 1);
      }
      const std::string exe = std::string(GONIO_BIN_DIR) + "/goniod";
      const auto st = state_.string(), cfg = (state_ / "test.toml").string();
      ::execl(exe.c_str(), exe.c_str(), "--state-dir", st.c_str(), "--config", cfg.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    const bool up = eventually([&] {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        throw std::runtime_error("goniod exited at start-up (status " +
                                 std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status)) +
                                 "): " + log_text());
      }
      try {
        Conn c = unix_conn();
        return c.request("system.info").contains("result");
      } catch (const std::exception&) {
        return false;
      }
    });
    if (!up) throw std::runtime_error("goniod did not come up: " + log_text());
    std::ifstream in(state_ / "endpoints.json");
    endpoints_ = json::parse(in);
  }
  // Signals goniod (sig 0: sends nothing) and waits for it; returns the exit status (128+sig
  // when killed).
  int stop(int sig = SIGTERM, std::chrono::milliseconds timeout = 20s) {
    ::kill(pid_, sig);
    int status = 0;
    const bool gone = eventually([&] { return ::waitpid(pid_, &status, WNOHANG) == pid_; }, timeout);
    if (!gone) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, &status, 0);
    }
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  pid_t pid() const { return pid_; }
  const fs::path& state() const { return state_; }
  std::string uri(const std::string& scheme) const {
    for (const auto& e : endpoints_["listen"])
      if (e.get<std::string>().starts_with(scheme)) return e.get<std::string>();
    throw std::runtime_error("no " + scheme + " listener");
  }
  int tcp_port() const { return port_of(uri("tcp://")); }
  int http_port() const { return port_of(uri("http://")); }
  Conn unix_conn() const { return Conn(connect_unix((state_ / "goniod.sock").string())); }
  Conn tcp_conn() const { return Conn(connect_tcp("127.0.0.1", tcp_port())); }
  std::string admin_token() const {
    std::ifstream in(state_ / "admin.token");
    std::string t;
    std::getline(in, t);
    return t;
  }
  std::string log_text() const {
    std::ifstream in(state_ / "goniod.log");
    std::stringstream ss;
    ss << in.rdbuf();
    auto s = ss.str();
    return s.size() > 4000 ? s.substr(s.size() - 4000) : s;
  }

 private:
  fs::path state_;
  std::vector<std::string> env_;
  pid_t pid_ = -1;
  json endpoints_;
};

// Creates a sample and submits a scan over `c`; returns the scan id.
inline std::int64_t submit(Conn& c, const std::string& sample, const std::string& bsdf, const json& plan) {
  const auto existing = c.request("sample.get", json{{"sample", sample}});
  if (existing.contains("error"))
    c.call("sample.create", json{{"name", sample}, {"bsdf", bsdf.empty() ? json(nullptr) : json(bsdf)}});
  json p = plan;
  p["sample"] = sample;
  return c.call("scan.submit", p)["id"].get<std::int64_t>();
}

inline json wait_state(Conn& c, std::int64_t scan, const std::vector<std::string>& states,
                       std::chrono::milliseconds timeout = 20s) {
  json sc;
  eventually([&] {
    sc = c.call("scan.get", json{{"scan", scan}});
    for (const auto& s : states)
      if (sc["state"] == s) return true;
    return false;
  }, timeout);
  return sc;
}

// gonio-devsim serving a SCPI photometer on TCP `want_port` (0: any), with the given extra
// arguments (e.g. --scpi-config FILE); `port` is the port it bound. stop() kills it at once,
// as a power cut would; the destructor does the same.
class Devsim {
 public:
  explicit Devsim(int want_port, std::vector<std::string> extra = {}) {
    int fds[2];
    if (::pipe(fds) != 0) throw std::runtime_error("pipe");
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, fds[1], 1);
    posix_spawn_file_actions_addclose(&fa, fds[0]);
    const std::string exe = std::string(GONIO_BIN_DIR) + "/gonio-devsim";
    std::vector<std::string> args{exe, "--scpi-tcp", std::to_string(want_port), "--sample", "lambert:albedo=0.5"};
    args.insert(args.end(), extra.begin(), extra.end());
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    const int rc = posix_spawn(&pid_, exe.c_str(), &fa, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    ::close(fds[1]);
    if (rc != 0) throw std::runtime_error("cannot start " + exe);
    FILE* f = ::fdopen(fds[0], "r");
    char line[256];
    while (std::fgets(line, sizeof line, f) != nullptr) {
      std::string s(line);
      if (!s.empty() && s.back() == '\n') s.pop_back();
      if (s.rfind("scpi-tcp ", 0) == 0) port = port_of(s);
      if (s == "ready") break;
    }
    std::fclose(f);
    if (port == 0) throw std::runtime_error("gonio-devsim printed no TCP endpoint");
  }
  ~Devsim() { stop(); }
  Devsim(const Devsim&) = delete;
  Devsim& operator=(const Devsim&) = delete;
  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }
  int port = 0;

 private:
  pid_t pid_ = -1;
};

}  // namespace gonio::test
