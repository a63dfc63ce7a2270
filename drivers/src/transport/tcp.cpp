// Raw TCP socket transport: getaddrinfo, non-blocking connect bounded by a timeout,
// TCP_NODELAY (SCPI commands are short and latency-bound).
#include "gonio/drivers/transport/tcp.hpp"

#include <cerrno>
#include <charconv>
#include <cstring>

#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/format.h>

#include "fd_stream.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio::drivers {
namespace {

std::uint16_t port_of(long long v, const std::string& field) {
  if (v < 1 || v > 65535) throw Error::out_of_range(field, static_cast<double>(v), 1, 65535);
  return static_cast<std::uint16_t>(v);
}

}  // namespace

TcpConfig TcpConfig::read(json_util::ObjectReader& r) {
  TcpConfig c;
  c.host = r.required<std::string>("host");
  if (c.host.empty()) throw Error::invalid(r.path("host"), "must not be empty");
  c.port = port_of(r.optional<long long>("port", 5025), r.path("port"));
  c.connect_timeout = std::chrono::milliseconds(r.optional_in<long long>("connect_timeout_ms", 3000, 1, 600000, " ms"));
  return c;
}

TcpConfig TcpConfig::parse(std::string_view text) {
  TcpConfig c;
  std::string_view host, port;
  if (!text.empty() && text.front() == '[') {  // [v6]:port
    const auto close = text.find(']');
    if (close == std::string_view::npos || close + 1 >= text.size() || text[close + 1] != ':')
      throw Error::invalid("tcp", fmt::format("'{}' is not [HOST]:PORT", text));
    host = text.substr(1, close - 1);
    port = text.substr(close + 2);
  } else {
    const auto colon = text.rfind(':');
    if (colon == std::string_view::npos || colon == 0)
      throw Error::invalid("tcp", fmt::format("'{}' is not HOST:PORT", text));
    host = text.substr(0, colon);
    port = text.substr(colon + 1);
  }
  long long p = 0;
  const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), p);
  if (ec != std::errc() || end != port.data() + port.size())
    throw Error::invalid("tcp.port", fmt::format("'{}' is not a port number", port));
  c.host = std::string(host);
  c.port = port_of(p, "tcp.port");
  return c;
}

std::string TcpConfig::describe() const {
  return host.find(':') != std::string::npos ? fmt::format("[{}]:{}", host, port)
                                             : fmt::format("{}:{}", host, port);
}

TransportPtr open_tcp(const TcpConfig& c) {
  const auto what = "tcp " + c.describe();
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* res = nullptr;
  const auto port = std::to_string(c.port);
  if (const int rc = ::getaddrinfo(c.host.c_str(), port.c_str(), &hints, &res); rc != 0)
    throw Error(Errc::not_found, fmt::format("{}: cannot resolve host: {}", what, ::gai_strerror(rc)));
  const auto deadline = deadline_after(c.connect_timeout);
  int last_err = ECONNREFUSED;
  for (addrinfo* ai = res; ai != nullptr; ai = ai->ai_next) {
    const int fd = ::socket(ai->ai_family, ai->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC,
                            ai->ai_protocol);
    if (fd < 0) {
      last_err = errno;
      continue;
    }
    int rc = ::connect(fd, ai->ai_addr, ai->ai_addrlen);
    if (rc != 0 && errno == EINPROGRESS) {
      pollfd pfd{fd, POLLOUT, 0};
      rc = ::poll(&pfd, 1, static_cast<int>(remaining(deadline).count()));
      if (rc == 0) {
        ::close(fd);
        ::freeaddrinfo(res);
        throw Error(Errc::timeout, fmt::format("{}: connect timed out", what));
      }
      int err = 0;
      socklen_t len = sizeof err;
      ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len);
      rc = err == 0 ? 0 : -1;
      errno = err;
    }
    if (rc == 0) {
      ::freeaddrinfo(res);
      const int one = 1;
      ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
      return std::make_unique<detail::FdStream>(fd, true, what);
    }
    last_err = errno;
    ::close(fd);
  }
  ::freeaddrinfo(res);
  if (last_err == ECONNREFUSED || last_err == EHOSTUNREACH || last_err == ENETUNREACH)
    throw Error(Errc::not_found, fmt::format("{}: {} (is the device on?)", what, std::strerror(last_err)));
  detail::throw_errno("connect", what, last_err);
}

}  // namespace gonio::drivers
