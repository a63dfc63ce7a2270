// Fuzz target: goniod's message framing on real sockets — NDJSON on a unix socket (one
// JSON-RPC message per line) and HTTP (POST /rpc, the WebSocket upgrade) on loopback TCP —
// in front of the daemon of daemon_fuzz.hpp, with small limits (4 KiB messages, 200 ms read
// timeout) so that the size limit and partial messages are reached. The first byte picks
// the listener, the rest is sent on a new connection, which is then half-closed; whatever
// comes back must be well-formed: NDJSON replies one JSON-RPC reply per line, HTTP replies
// starting with a status line. A crash, a hang, or a malformed reply is a finding.
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <thread>

#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>

#include "daemon_fuzz.hpp"
#include "gonio/daemon/net/net.hpp"

namespace {

struct Servers {
  Servers() : d(gonio::fuzz::FuzzDaemon::get()), work(io.get_executor()) {
    gonio::daemon::net::Limits limits;
    limits.max_message_bytes = 4096;
    limits.read_timeout = std::chrono::milliseconds(200);
    limits.max_in_flight = 4;
    ctx = std::make_unique<gonio::daemon::net::Context>(
        gonio::daemon::net::Context{d.dispatcher, d.hub, *d.auth, limits, stats, nullptr, {}, nullptr});
    unix_path = (d.dir / "fuzz.sock").string();
    ndjson = gonio::daemon::net::listen_unix(io, unix_path, *ctx);
    http = gonio::daemon::net::listen_http(io, "127.0.0.1", 0, *ctx);
    const auto ep = http->endpoint();
    http_port = static_cast<std::uint16_t>(std::stoi(ep.substr(ep.rfind(':') + 1)));
    thread = std::thread([this] { io.run(); });
  }
  static Servers& get() {
    static auto* s = new Servers;
    return *s;
  }
  gonio::fuzz::FuzzDaemon& d;
  gonio::daemon::net::NetStats stats;
  boost::asio::io_context io;
  boost::asio::executor_work_guard<boost::asio::io_context::executor_type> work;
  std::unique_ptr<gonio::daemon::net::Context> ctx;
  std::shared_ptr<gonio::daemon::net::Listener> ndjson, http;
  std::string unix_path;
  std::uint16_t http_port = 0;
  std::thread thread;
};

int connect_to(bool over_http, const Servers& s) {
  if (over_http) {
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(s.http_port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) std::abort();
    return fd;
  }
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::strncpy(a.sun_path, s.unix_path.c_str(), sizeof a.sun_path - 1);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) std::abort();
  return fd;
}

// Writes what the peer takes and reads everything until the server closes or goes quiet.
std::string exchange(int fd, std::string_view out) {
  std::string in;
  std::size_t sent = 0;
  bool write_closed = false;
  for (;;) {
    if (sent == out.size() && !write_closed) {
      ::shutdown(fd, SHUT_WR);
      write_closed = true;
    }
    pollfd p{fd, static_cast<short>(POLLIN | (write_closed ? 0 : POLLOUT)), 0};
    if (::poll(&p, 1, 2000) <= 0) break;  // quiet: what came back is checked as it is
    if (p.revents & POLLIN) {
      char buf[65536];
      const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
      if (n <= 0) break;
      in.append(buf, static_cast<std::size_t>(n));
      if (in.size() > (8u << 20)) break;
    } else if (p.revents & POLLOUT) {
      const ssize_t n = ::send(fd, out.data() + sent, out.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) {
        write_closed = true;  // the server closed on us (a limit): read its last words
        continue;
      }
      sent += static_cast<std::size_t>(n);
    } else {
      break;
    }
  }
  return in;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  auto& s = Servers::get();
  const bool over_http = (data[0] & 1) != 0;
  const std::string_view out(reinterpret_cast<const char*>(data) + 1, size - 1);
  const int fd = connect_to(over_http, s);
  const auto in = exchange(fd, out);
  ::close(fd);
  if (over_http) {
    // Beast answers in the request's version: HTTP/1.0 to an HTTP/1.0 request.
    if (!in.empty() && in.rfind("HTTP/1.1 ", 0) != 0 && in.rfind("HTTP/1.0 ", 0) != 0)
      gonio::fuzz::fail("not an HTTP/1.x status line", in);
    return 0;
  }
  // Every complete line is one reply; a line cut short is allowed only at the end.
  std::size_t start = 0;
  for (auto nl = in.find('\n'); nl != std::string::npos; nl = in.find('\n', start)) {
    gonio::fuzz::check_reply(std::string_view(in).substr(start, nl - start));
    start = nl + 1;
  }
  return 0;
}
