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

#include <cctype>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstdint>
#include <cstring>
#include <iterator>

#include <fmt/format.h>
#include <openssl/err.h>
#include <openssl/ssl.h>
#include <openssl/x509v3.h>

namespace gonio::daemon {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

int remaining_ms(Clock::time_point deadline) {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
  return ms < 0 ? 0 : static_cast<int>(std::min<long long>(ms, 1 << 30));
}

// tcp://HOST:PORT, tls://HOST:PORT, https://HOST:PORT/rpc, [IPv6]:PORT → host and port.
std::pair<std::string, std::string> host_port(const std::string& uri) {
  std::string rest = uri.substr(uri.find("://") + 3);
  rest = rest.substr(0, rest.find('/'));
  if (!rest.empty() && rest.front() == '[') {
    const auto close = rest.find("]:");
    if (close == std::string::npos) throw ConnectionError(fmt::format("{}: bad address", uri));
    return {rest.substr(1, close - 1), rest.substr(close + 2)};
  }
  const auto colon = rest.rfind(':');
  if (colon == std::string::npos) throw ConnectionError(fmt::format("{}: expected HOST:PORT", uri));
  return {rest.substr(0, colon), rest.substr(colon + 1)};
}

// The last OpenSSL error of this thread, the queue cleared.
std::string openssl_error() {
  unsigned long last = 0;
  while (const unsigned long e = ERR_get_error()) last = e;
  if (last == 0) return std::strerror(errno);
  char text[256];
  ERR_error_string_n(last, text, sizeof text);
  return text;
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
  if (uri.starts_with("tcp://") || uri.starts_with("tls://") || uri.starts_with("http://") ||
      uri.starts_with("https://")) {
    const auto [host, port] = host_port(uri);
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
  throw ConnectionError(fmt::format("'{}' is not unix:PATH, tcp://HOST:PORT, tls://HOST:PORT, "
                                    "http://HOST:PORT or https://HOST:PORT", uri));
}

Client::Client(const std::string& uri, std::chrono::milliseconds timeout, const std::string& ca)
    : fd_(connect_uri(uri, timeout)), http_(uri.starts_with("http://") || uri.starts_with("https://")),
      uri_(uri), timeout_(timeout) {
  if (!uri.starts_with("tls://") && !uri.starts_with("https://")) return;
  try {
    start_tls(ca);
  } catch (...) {
    close_connection();  // no destructor for a constructor that throws
    throw;
  }
}

Client::~Client() { close_connection(); }

void Client::close_connection() noexcept {
  if (tls_) SSL_free(tls_);
  if (tls_ctx_) SSL_CTX_free(tls_ctx_);
  if (fd_ >= 0) ::close(fd_);
  tls_ = nullptr, tls_ctx_ = nullptr, fd_ = -1;
}

Client::Client(Client&& o) noexcept
    : fd_(o.fd_), tls_ctx_(o.tls_ctx_), tls_(o.tls_), http_(o.http_), token_(std::move(o.token_)),
      uri_(std::move(o.uri_)), timeout_(o.timeout_),
      buffer_(std::move(o.buffer_)), consumed_(o.consumed_), notifications_(std::move(o.notifications_)),
      next_id_(o.next_id_) {
  o.fd_ = -1;
  o.tls_ctx_ = nullptr;
  o.tls_ = nullptr;
}

// TLS 1.2 or 1.3; the certificate must chain to `ca` (else the system's CAs) and name the
// URI's host (RFC 6125: a DNS name, or an IP address in subjectAltName).
void Client::start_tls(const std::string& ca) {
  // OpenSSL writes with write(2): a server that has gone would otherwise end gonioctl by SIGPIPE.
  std::signal(SIGPIPE, SIG_IGN);
  tls_ctx_ = SSL_CTX_new(TLS_client_method());
  if (!tls_ctx_ || SSL_CTX_set_min_proto_version(tls_ctx_, TLS1_2_VERSION) != 1)
    throw ConnectionError(fmt::format("{}: OpenSSL: {}", uri_, openssl_error()));
  if (ca.empty() ? SSL_CTX_set_default_verify_paths(tls_ctx_) != 1
                 : SSL_CTX_load_verify_locations(tls_ctx_, ca.c_str(), nullptr) != 1)
    throw ConnectionError(fmt::format("--ca {}: cannot read CA certificates: {}", ca, openssl_error()));
  SSL_CTX_set_verify(tls_ctx_, SSL_VERIFY_PEER, nullptr);
  tls_ = SSL_new(tls_ctx_);
  if (!tls_ || SSL_set_fd(tls_, fd_) != 1) throw ConnectionError(fmt::format("{}: OpenSSL: {}", uri_, openssl_error()));
  const auto host = host_port(uri_).first;
  unsigned char ip[16];
  const bool literal = inet_pton(AF_INET, host.c_str(), ip) == 1 || inet_pton(AF_INET6, host.c_str(), ip) == 1;
  if (literal) {
    X509_VERIFY_PARAM_set1_ip_asc(SSL_get0_param(tls_), host.c_str());
  } else {
    SSL_set1_host(tls_, host.c_str());
    // SNI (SSL_set_tlsext_host_name, a macro with a C cast)
    SSL_ctrl(tls_, SSL_CTRL_SET_TLSEXT_HOSTNAME, TLSEXT_NAMETYPE_host_name, const_cast<char*>(host.c_str()));
  }
  // The handshake, like every read, waits at most the timeout.
  timeval tv{static_cast<time_t>(timeout_.count() / 1000), static_cast<suseconds_t>(timeout_.count() % 1000 * 1000)};
  ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  ::setsockopt(fd_, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  if (SSL_connect(tls_) != 1) {
    const long verify = SSL_get_verify_result(tls_);
    if (verify != X509_V_OK)
      throw ConnectionError(fmt::format("{}: the server's certificate is not trusted: {}{}", uri_,
                                        X509_verify_cert_error_string(verify),
                                        ca.empty() ? " (name the CA that signed it with --ca FILE)" : ""));
    throw ConnectionError(fmt::format("{}: TLS handshake failed: {}", uri_, openssl_error()));
  }
}

long Client::receive(char* buf, std::size_t size) {
  if (!tls_) {
    const auto n = ::recv(fd_, buf, size, 0);
    if (n < 0 && errno == EINTR) return 0;
    if (n < 0) throw ConnectionError(fmt::format("{}: recv: {}", uri_, std::strerror(errno)));
    if (n == 0) throw ConnectionError(fmt::format("{}: the server closed the connection", uri_));
    return n;
  }
  const int n = SSL_read(tls_, buf, static_cast<int>(std::min<std::size_t>(size, 1 << 30)));
  if (n > 0) return n;
  switch (SSL_get_error(tls_, n)) {
    case SSL_ERROR_WANT_READ:
    case SSL_ERROR_WANT_WRITE: return 0;  // a record without data (a TLS 1.3 session ticket)
    case SSL_ERROR_ZERO_RETURN: throw ConnectionError(fmt::format("{}: the server closed the connection", uri_));
    default:
      if (errno == EAGAIN || errno == EWOULDBLOCK)
        throw ConnectionError(fmt::format("{}: no data within {} s", uri_, timeout_.count() / 1000.0));
      ERR_clear_error();
      // goniod closes without a close_notify: an end of the stream is the server closing.
      throw ConnectionError(fmt::format("{}: the server closed the connection", uri_));
  }
}

void Client::send_all(std::string_view data) {
  if (tls_) {
    if (data.empty()) return;
    if (SSL_write(tls_, data.data(), static_cast<int>(data.size())) <= 0)
      throw ConnectionError(fmt::format("{}: send: {}", uri_, openssl_error()));
    return;
  }
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

bool Client::receive_more(Clock::time_point deadline) {
  // Bytes OpenSSL has already decrypted are not on the socket any more.
  if (!tls_ || SSL_pending(tls_) == 0) {
    pollfd p{fd_, POLLIN, 0};
    int rc = 0;
    while ((rc = ::poll(&p, 1, remaining_ms(deadline))) < 0 && errno == EINTR) {
    }
    if (rc < 0) throw ConnectionError(fmt::format("{}: poll: {}", uri_, std::strerror(errno)));
    if (rc == 0) return false;
  }
  char buf[65536];
  const auto n = receive(buf, sizeof buf);
  buffer_.append(buf, static_cast<std::size_t>(n));
  return true;
}

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
    if (!receive_more(deadline)) return std::nullopt;
  }
}

// HTTP/1.1 (RFC 9112): the body of the next response, by its Content-Length; valid until
// the next read. Any status: goniod's refusals carry a JSON-RPC error as their body.
std::optional<std::string_view> Client::next_body(std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  buffer_.erase(0, consumed_);
  consumed_ = 0;
  for (;;) {
    if (const auto end = buffer_.find("\r\n\r\n"); end != std::string::npos) {
      std::string head = buffer_.substr(0, end);
      for (auto& ch : head) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
      const auto at = head.find("\r\ncontent-length:");
      if (at == std::string::npos) throw ConnectionError(fmt::format("{}: a response without Content-Length", uri_));
      const auto length = std::strtoull(head.c_str() + at + 17, nullptr, 10);
      if (buffer_.size() >= end + 4 + length) {
        consumed_ = end + 4 + length;
        return std::string_view(buffer_.data() + end + 4, length);
      }
    }
    if (!receive_more(deadline)) return std::nullopt;
  }
}

std::int64_t Client::send_request(const std::string& method, const json& params) {
  const auto id = next_id_++;
  out_.clear();
  if (http_) {  // POST /rpc, one call per request on a kept-alive connection
    const auto body = fmt::format(R"({{"jsonrpc":"2.0","id":{},"method":{},"params":{}}})", id,
                                  json(method).dump(), params.dump());
    const auto [host, port] = host_port(uri_);
    const bool v6 = host.find(':') != std::string::npos;
    fmt::format_to(std::back_inserter(out_),
                   "POST /rpc HTTP/1.1\r\nHost: {}{}{}:{}\r\nContent-Type: application/json\r\n"
                   "Content-Length: {}\r\n{}\r\n{}",
                   v6 ? "[" : "", host, v6 ? "]" : "", port, body.size(),
                   token_.empty() ? std::string() : "Authorization: Bearer " + token_ + "\r\n", body);
  } else {
    fmt::format_to(std::back_inserter(out_), R"({{"jsonrpc":"2.0","id":{},"method":{},"params":{}}})"
                   "\n", id, json(method).dump(), params.dump());
  }
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
    const auto wait = std::chrono::milliseconds(remaining_ms(deadline));
    const auto line = http_ ? next_body(wait) : next_line(wait);
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

json Client::login(const std::string& token) {
  if (http_) token_ = token;  // over HTTP every request carries it (Authorization: Bearer)
  return call("auth.login", json{{"token", token}});
}

std::optional<json> Client::next_notification(std::chrono::milliseconds timeout) {
  if (http_)
    throw ConnectionError(fmt::format("{}: HTTP carries no notifications: connect with unix:, tcp:// or tls://", uri_));
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
