// Blocking NDJSON JSON-RPC client (see client.hpp).
#include "gonio/daemon/ctl/client.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <iterator>

#include <fmt/format.h>

namespace gonio::daemon {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

int remaining_ms(Clock::time_point deadline) {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
  return ms < 0 ? 0 : static_cast<int>(std::min<long long>(ms, 1 << 30));
}

}  // namespace

int connect_uri(const std::string& uri, std::chrono::milliseconds timeout) {
  if (uri.starts_with("unix:")) {
    const auto path = uri.substr(5);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    if (path.size() >= sizeof addr.sun_path) throw ConnectionError(fmt::format("{}: path too long", uri));
    std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
    const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) throw ConnectionError(fmt::format("socket: {}", std::strerror(errno)));
    if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      const int e = errno;
      ::close(fd);
      throw ConnectionError(fmt::format("cannot connect to {}: {}", uri, std::strerror(e)));
    }
    return fd;
  }
  if (uri.starts_with("tcp://")) {
    std::string rest = uri.substr(6), host, port;
    if (!rest.empty() && rest.back() == '/') rest.pop_back();
    if (!rest.empty() && rest.front() == '[') {
      const auto close = rest.find("]:");
      if (close == std::string::npos) throw ConnectionError(fmt::format("{}: bad address", uri));
      host = rest.substr(1, close - 1), port = rest.substr(close + 2);
    } else {
      const auto colon = rest.rfind(':');
      if (colon == std::string::npos) throw ConnectionError(fmt::format("{}: expected HOST:PORT", uri));
      host = rest.substr(0, colon), port = rest.substr(colon + 1);
    }
    addrinfo hints{};
    hints.ai_socktype = SOCK_STREAM;
    addrinfo* res = nullptr;
    if (const int rc = ::getaddrinfo(host.c_str(), port.c_str(), &hints, &res); rc != 0)
      throw ConnectionError(fmt::format("{}: {}", uri, gai_strerror(rc)));
    int fd = -1;
    std::string last = "no address";
    for (auto* ai = res; ai; ai = ai->ai_next) {
      fd = ::socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC | SOCK_NONBLOCK, ai->ai_protocol);
      if (fd < 0) continue;
      int rc = ::connect(fd, ai->ai_addr, ai->ai_addrlen);
      if (rc != 0 && errno == EINPROGRESS) {
        pollfd p{fd, POLLOUT, 0};
        rc = ::poll(&p, 1, static_cast<int>(timeout.count())) == 1 ? 0 : -1;
        int err = 0;
        socklen_t len = sizeof err;
        if (rc == 0 && (::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len) != 0 || err != 0)) {
          errno = err ? err : errno;
          rc = -1;
        } else if (rc != 0) {
          errno = ETIMEDOUT;
        }
      }
      if (rc == 0) {
        ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
        int one = 1;
        ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        break;
      }
      last = std::strerror(errno);
      ::close(fd);
      fd = -1;
    }
    ::freeaddrinfo(res);
    if (fd < 0) throw ConnectionError(fmt::format("cannot connect to {}: {}", uri, last));
    return fd;
  }
  throw ConnectionError(fmt::format("'{}' is not unix:PATH or tcp://HOST:PORT", uri));
}

Client::Client(const std::string& uri, std::chrono::milliseconds timeout)
    : fd_(connect_uri(uri, timeout)), uri_(uri), timeout_(timeout) {}

Client::~Client() {
  if (fd_ >= 0) ::close(fd_);
}

Client::Client(Client&& o) noexcept
    : fd_(o.fd_), uri_(std::move(o.uri_)), timeout_(o.timeout_), buffer_(std::move(o.buffer_)),
      consumed_(o.consumed_), notifications_(std::move(o.notifications_)), next_id_(o.next_id_) {
  o.fd_ = -1;
}

void Client::send_all(std::string_view data) {
  std::size_t off = 0;
  while (off < data.size()) {
    const auto n = ::send(fd_, data.data() + off, data.size() - off, MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw ConnectionError(fmt::format("{}: send: {}", uri_, std::strerror(errno)));
    }
    off += static_cast<std::size_t>(n);
  }
}

void Client::send_line(const std::string& line) { send_all(line + "\n"); }

std::optional<std::string_view> Client::next_line(std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  if (consumed_ == buffer_.size() || consumed_ > 65536) {  // the previous line's view ends here
    buffer_.erase(0, consumed_);
    consumed_ = 0;
  }
  for (std::size_t searched = consumed_;;) {
    if (const auto nl = buffer_.find('\n', searched); nl != std::string::npos) {
      const std::string_view line(buffer_.data() + consumed_, nl - consumed_);
      consumed_ = nl + 1;
      return line;
    }
    searched = buffer_.size();
    pollfd p{fd_, POLLIN, 0};
    const int rc = ::poll(&p, 1, remaining_ms(deadline));
    if (rc < 0 && errno == EINTR) continue;
    if (rc < 0) throw ConnectionError(fmt::format("{}: poll: {}", uri_, std::strerror(errno)));
    if (rc == 0) return std::nullopt;
    char buf[65536];
    const auto n = ::recv(fd_, buf, sizeof buf, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw ConnectionError(fmt::format("{}: recv: {}", uri_, std::strerror(errno)));
    if (n == 0) throw ConnectionError(fmt::format("{}: the server closed the connection", uri_));
    buffer_.append(buf, static_cast<std::size_t>(n));
  }
}

std::optional<std::string> Client::read_line(std::chrono::milliseconds timeout) {
  const auto line = next_line(timeout);
  if (!line) return std::nullopt;
  return std::string(*line);
}

std::int64_t Client::send_request(const std::string& method, const json& params) {
  const auto id = next_id_++;
  out_.clear();
  fmt::format_to(std::back_inserter(out_), R"({{"jsonrpc":"2.0","id":{},"method":{},"params":{}}})"
                 "\n", id, json(method).dump(), params.dump());
  send_all(out_);
  return id;
}

namespace {

// The top-level members of an answer that matter to a caller that wants only to know it
// arrived: its id and whether it is an error. Everything else is read and dropped.
struct Envelope : nlohmann::json_sax<json> {
  int depth = 0;
  bool at_id = false, has_id = false, has_error = false;
  std::optional<std::int64_t> id;

  bool value() {
    at_id = false;
    return true;
  }
  bool null() override { return value(); }
  bool boolean(bool) override { return value(); }
  bool number_integer(number_integer_t v) override {
    if (at_id) id = v;
    return value();
  }
  bool number_unsigned(number_unsigned_t v) override {
    if (at_id && v <= static_cast<number_unsigned_t>(INT64_MAX)) id = static_cast<std::int64_t>(v);
    return value();
  }
  bool number_float(number_float_t, const string_t&) override { return value(); }
  bool string(string_t&) override { return value(); }
  bool binary(binary_t&) override { return value(); }
  bool start_object(std::size_t) override {
    at_id = false;
    ++depth;
    return true;
  }
  bool key(string_t& k) override {
    if (depth == 1) {
      at_id = k == "id";
      has_id = has_id || at_id;
      has_error = has_error || k == "error";
    }
    return true;
  }
  bool end_object() override {
    --depth;
    return true;
  }
  bool start_array(std::size_t) override {
    at_id = false;
    ++depth;
    return true;
  }
  bool end_array() override {
    --depth;
    return true;
  }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) override { return false; }
};

[[noreturn]] void throw_error(const json& msg) {
  const auto& e = msg["error"];
  throw RpcError(e.value("code", 0), e.value("message", ""), e.value("data", json::object()));
}

}  // namespace

void Client::await(std::int64_t id, const std::string& method, bool full, json& msg) {
  const auto deadline = Clock::now() + timeout_;
  for (;;) {
    const auto line = next_line(std::chrono::milliseconds(remaining_ms(deadline)));
    if (!line) throw ConnectionError(fmt::format("{}: no answer to {} within {} s", uri_, method,
                                                 timeout_.count() / 1000.0));
    if (!full) {
      Envelope env;
      if (!json::sax_parse(line->begin(), line->end(), &env))
        throw ConnectionError(fmt::format("{}: unreadable reply", uri_));
      if (env.has_id && !env.has_error && env.id == id) return;
      // An error, a notification or an answer to something else: read whole below.
    }
    msg = json::parse(line->begin(), line->end(), nullptr, false);
    if (msg.is_discarded()) throw ConnectionError(fmt::format("{}: unreadable reply", uri_));
    const auto it = msg.find("id");
    if (it == msg.end()) {
      notifications_.push_back(std::move(msg));
      continue;
    }
    const bool ours = it->is_number_integer() && it->get<std::int64_t>() == id;
    if (!ours && !(it->is_null() && msg.contains("error"))) continue;  // an answer to something else
    if (msg.contains("error")) throw_error(msg);
    return;
  }
}

json Client::call(const std::string& method, const json& params) {
  json msg;
  await(send_request(method, params), method, true, msg);
  return std::move(msg["result"]);
}

void Client::call_checked(const std::string& method, const json& params) {
  json msg;
  await(send_request(method, params), method, false, msg);
}

json Client::login(const std::string& token) { return call("auth.login", json{{"token", token}}); }

std::optional<json> Client::next_notification(std::chrono::milliseconds timeout) {
  if (!notifications_.empty()) {
    auto n = std::move(notifications_.front());
    notifications_.pop_front();
    return n;
  }
  const auto deadline = Clock::now() + timeout;
  for (;;) {
    const auto line = next_line(std::chrono::milliseconds(remaining_ms(deadline)));
    if (!line) return std::nullopt;
    json msg = json::parse(line->begin(), line->end(), nullptr, false);
    if (msg.is_discarded()) continue;
    if (!msg.contains("id")) return msg;
  }
}

}  // namespace gonio::daemon
