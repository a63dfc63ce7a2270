// HTTP POST /rpc and WebSocket /ws via Boost.Beast, plain or over TLS (see net.hpp).
#include <algorithm>
#include <atomic>
#include <cctype>
#include <mutex>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <boost/beast/websocket.hpp>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/net/net.hpp"
#include "net/accept.hpp"
#include "net/session.hpp"
#include "net/tls.hpp"
#include "net/ws_session.hpp"

namespace gonio::daemon::net {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using boost::system::error_code;
using tcp = asio::ip::tcp;
using nlohmann::json;

namespace {

constexpr std::size_t kHeaderLimit = 16 * 1024;

// "Bearer TOKEN" → TOKEN (scheme case-insensitive, RFC 6750 §2.1); empty when absent.
std::string bearer(beast::string_view header) {
  std::string h(header);
  if (h.size() < 7) return {};
  std::string scheme = h.substr(0, 7);
  for (auto& ch : scheme) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  if (scheme != "bearer ") return {};
  auto token = h.substr(7);
  while (!token.empty() && token.front() == ' ') token.erase(0, 1);
  while (!token.empty() && token.back() == ' ') token.pop_back();
  return token;
}

std::string error_body(int code, std::string_view msg, Errc errc, std::string_view field = {}) {
  // msg may quote the peer's bytes (the target, Origin, Content-Type): never UTF-8 by promise.
  return rpc::json_text(json{{"jsonrpc", "2.0"}, {"error", rpc::error_object(code, msg, errc, field)}, {"id", nullptr}});
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (auto& ch : out) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return out;
}

// Whether a browser's Origin may talk to this listener: its own host (the Host header the
// browser sent with it) or one of server.allowed_origins. "null" (sandboxed frames, files)
// never may.
bool origin_allowed(std::string_view origin, std::string_view host, const Limits& limits) {
  const auto o = lower(origin);
  for (const auto& a : limits.allowed_origins)
    if (lower(a) == o) return true;
  if (host.empty()) return false;
  return o == "http://" + lower(host) || o == "https://" + lower(host);
}

bool listed_origin(std::string_view origin, const Limits& limits) {
  const auto o = lower(origin);
  for (const auto& a : limits.allowed_origins)
    if (lower(a) == o) return true;
  return false;
}

// "application/json" with optional parameters ("; charset=utf-8"), any case.
bool is_json_media_type(std::string_view content_type) {
  auto t = lower(content_type.substr(0, content_type.find(';')));
  while (!t.empty() && t.back() == ' ') t.pop_back();
  while (!t.empty() && t.front() == ' ') t.erase(0, 1);
  return t == "application/json";
}

// The dashboard's Content-Security-Policy: nothing but its own files, no inline script or
// style, and connections only back to this listener (the WebSocket by the Host the browser
// used; a Host that is not a plain host[:port] gets 'self' alone).
std::string content_security_policy(std::string_view host) {
  const bool plain = !host.empty() && host.size() <= 255 &&
                     std::all_of(host.begin(), host.end(), [](char c) {
                       return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' ||
                              c == ':' || c == '[' || c == ']';
                     });
  const auto ws = plain ? fmt::format(" ws://{0} wss://{0}", host) : std::string{};
  return fmt::format("default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data: blob:; "
                     "connect-src 'self'{}; object-src 'none'; base-uri 'none'; form-action 'self'; "
                     "frame-ancestors 'none'",
                     ws);
}

// A request over HTTP POST: no notifications can reach it.
class OneShot final : public rpc::Session {
 public:
  OneShot(const char* transport, std::string peer, Principal p) : rpc::Session(transport, std::move(peer), false) {
    set_principal(std::move(p));
  }
  bool push(std::shared_ptr<const std::string>) override { return false; }
};

// ---- HTTP ---------------------------------------------------------------------------------

// `Stream`: beast::tcp_stream, or beast::ssl_stream over it (https://).
template <class Stream>
class HttpSession final : public std::enable_shared_from_this<HttpSession<Stream>> {
  using std::enable_shared_from_this<HttpSession<Stream>>::shared_from_this;
  static constexpr bool kTls = !std::is_same_v<Stream, beast::tcp_stream>;

 public:
  HttpSession(Stream stream, std::shared_ptr<HttpState> st)
      : stream_(std::move(stream)), ex_(stream_.get_executor()), st_(std::move(st)), limits_(st_->ctx.limits) {
    error_code ec;
    const auto ep = tcp_().socket().remote_endpoint(ec);
    peer_ = ec ? "?" : fmt::format("{}:{}", ep.address().to_string(), ep.port());
  }
  ~HttpSession() { --st_->connections; }

  void start() {
    auto self = shared_from_this();
    st_->add_closer(self, [w = std::weak_ptr<HttpSession>(self)] {
      auto s = w.lock();
      if (!s) return;
      ++s->st_->ending;
      asio::post(s->ex_, [s] {
        if (!s->upgraded_) s->close_now();
        --s->st_->ending;
      });
    });
    if constexpr (kTls) {
      // The handshake has read_timeout to finish, as a request; until then the peer is owed
      // nothing and holds no buffers but OpenSSL's.
      tcp_().expires_after(limits_.read_timeout);
      stream_.async_handshake(asio::ssl::stream_base::server, [self](const error_code& ec) {
        if (ec) {
          ++self->st_->dropped;
          spdlog::info("https {}: TLS handshake {}", self->peer_,
                       ec == beast::error::timeout ? fmt::format("did not complete within {} s",
                                                                 std::chrono::duration<double>(self->limits_.read_timeout).count())
                                                   : "failed: " + ec.message());
          return self->close_now();
        }
        self->certified_ = certificate_principal(self->stream_.native_handle(), self->st_->ctx.auth, "https");
        self->do_read();
      });
      return;
    }
    do_read();
  }

 private:
  beast::tcp_stream& tcp_() { return beast::get_lowest_layer(stream_); }

  void close_now() {
    error_code ignored;
    tcp_().socket().shutdown(tcp::socket::shutdown_both, ignored);
    tcp_().close();
  }

  void do_read() {
    parser_.emplace();
    parser_->body_limit(limits_.max_message_bytes);
    parser_->header_limit(kHeaderLimit);
    // One deadline for the whole request (a keep-alive connection waits at most this long
    // for the next one).
    tcp_().expires_after(limits_.read_timeout);
    http::async_read(stream_, buffer_, *parser_, [self = shared_from_this()](const error_code& ec, std::size_t) {
      self->on_read(ec);
    });
  }

  void on_read(const error_code& ec) {
    if (ec == http::error::end_of_stream || ec == asio::error::eof) return close();
    if (ec == http::error::body_limit || ec == http::error::header_limit) {
      ++st_->dropped;
      spdlog::warn("http {}: request larger than the limit; closing", peer_);
      return send(http::status::payload_too_large,
                  error_body(rpc::code::invalid_request,
                             fmt::format("message exceeds the limit of {} bytes",
                                         limits_.max_message_bytes),
                             Errc::out_of_range),
                  false, 11);
    }
    if (ec) {
      if (ec == beast::error::timeout) ++st_->dropped;
      return close();
    }
    auto req = parser_->release();
    const auto target = std::string(req.target());
    const auto origin = std::string(req[http::field::origin]);
    const auto host = std::string(req[http::field::host]);
    // A browser names the page's origin: only the listener's own host and the configured
    // origins may use the API from a page (a foreign page could otherwise drive the
    // instrument through a browser on the lab PC).
    if (req.find(http::field::origin) != req.end() && !origin_allowed(origin, host, limits_)) {
      ++st_->ctx.stats.refused_origin;
      spdlog::warn("http {}: refused a request from origin '{}'", peer_, origin);
      return send(http::status::forbidden,
                  error_body(rpc::code::forbidden,
                             fmt::format("origin '{}' may not use this API (allowed: this host and "
                                         "server.allowed_origins)",
                                         origin),
                             Errc::forbidden, "Origin"),
                  false, req.version());
    }
    cors_origin_ = req.find(http::field::origin) != req.end() && listed_origin(origin, limits_) ? origin : "";
    if (req.method() == http::verb::options && target == "/rpc" && !cors_origin_.empty())
      return send(http::status::no_content, {}, req.keep_alive(), req.version(), false, "POST, OPTIONS");
    const auto token = bearer(req[http::field::authorization]);
    std::optional<Principal> who;
    if (!token.empty()) {
      who = st_->ctx.auth.authenticate(token, websocket::is_upgrade(req) ? st_->ws_transport() : st_->http_transport());
      if (!who)
        return send(http::status::unauthorized,
                    error_body(rpc::code::unauthorized, "unknown bearer token", Errc::unauthorized),
                    req.keep_alive(), req.version(), true);
    }
    if (websocket::is_upgrade(req)) {
      if (target != "/ws")
        return send(http::status::not_found,
                    error_body(rpc::code::method_not_found, "WebSocket endpoint is /ws", Errc::not_found),
                    false, req.version());
      tcp_().expires_never();
      upgraded_ = true;
      if (!who && certified_) who = as(*certified_, st_->ws_transport());
      start_websocket(std::move(stream_), peer_, st_, std::move(who), std::move(req));
      return;
    }
    if (target != "/rpc" && st_->ctx.web && (req.method() == http::verb::get))
      if (const auto* file = st_->ctx.web->find(target)) return send_file(*file, host, req.keep_alive(), req.version());
    if (target != "/rpc")
      return send(http::status::not_found,
                  error_body(rpc::code::method_not_found,
                             fmt::format("no resource {} (POST /rpc, GET /ws)", target),
                             Errc::not_found),
                  req.keep_alive(), req.version());
    if (req.method() != http::verb::post)
      return send(http::status::method_not_allowed,
                  error_body(rpc::code::invalid_request, "use POST for /rpc", Errc::invalid_argument),
                  req.keep_alive(), req.version(), false, "POST");
    // A form or a no-cors fetch cannot send application/json across origins without a
    // preflight: requiring it keeps cross-origin simple requests out.
    if (!is_json_media_type(std::string(req[http::field::content_type]))) {
      ++st_->ctx.stats.refused_content_type;
      return send(http::status::unsupported_media_type,
                  error_body(rpc::code::invalid_request,
                             fmt::format("Content-Type '{}' is not application/json",
                                         std::string(req[http::field::content_type])),
                             Errc::invalid_argument, "Content-Type"),
                  false, req.version());
    }
    Principal p;
    p.transport = st_->http_transport();
    p.name = "anonymous";
    if (who) p = *who;
    else if (certified_) p = *certified_;
    auto session = std::make_shared<OneShot>(st_->http_transport(), peer_, p);
    const bool keep = req.keep_alive();
    const unsigned version = req.version();
    st_->ctx.dispatcher.handle(req.body(), session, [self = shared_from_this(), keep, version](std::string r) {
      asio::post(self->ex_, [self, keep, version, r = std::move(r)]() mutable {
        if (r.empty()) return self->send(http::status::no_content, {}, keep, version);
        // The answer is held until written: it counts against the shared output budget.
        auto& buffered = self->st_->ctx.stats.buffered_bytes;
        if (buffered.load() + r.size() > self->limits_.max_buffered_bytes && r.size() > kReadPauseBytes)
          return self->send(http::status::service_unavailable,
                            error_body(rpc::code::overloaded,
                                       fmt::format("goniod's output buffers are full (limit "
                                                   "server.max_buffered_bytes = {}); retry later",
                                                   self->limits_.max_buffered_bytes),
                                       Errc::busy),
                            false, version);
        self->send(http::status::ok, std::move(r), keep, version);
      });
    });
  }

  // One of the dashboard's files; the body is copied into the response, and counts against
  // the shared output budget like any answer.
  void send_file(const WebFile& file, std::string_view host, bool keep_alive, unsigned version) {
    auto res = std::make_shared<http::response<http::string_body>>(http::status::ok, version);
    res->set(http::field::server, "goniod");
    res->set(http::field::content_type, file.content_type);
    res->set(http::field::cache_control, file.cache_control);
    res->set("Content-Security-Policy", content_security_policy(host));
    res->set("X-Content-Type-Options", "nosniff");
    res->set("Referrer-Policy", "no-referrer");
    res->set("X-Frame-Options", "DENY");
    res->keep_alive(keep_alive);
    res->body() = file.body;
    res->prepare_payload();
    write(std::move(res));
  }

  void send(http::status status, std::string body, bool keep_alive, unsigned version,
            bool challenge = false, const char* allow = nullptr) {
    auto res = std::make_shared<http::response<http::string_body>>(status, version);
    res->set(http::field::server, "goniod");
    if (!body.empty()) res->set(http::field::content_type, "application/json");
    if (challenge) res->set(http::field::www_authenticate, "Bearer realm=\"goniod\"");
    if (allow) res->set(http::field::allow, allow);
    if (!cors_origin_.empty()) {
      res->set(http::field::access_control_allow_origin, cors_origin_);
      res->set(http::field::vary, "Origin");
      if (status == http::status::no_content && allow) {  // a preflight
        res->set(http::field::access_control_allow_methods, "POST");
        res->set(http::field::access_control_allow_headers, "Authorization, Content-Type");
        res->set(http::field::access_control_max_age, "600");
      }
    }
    res->keep_alive(keep_alive);
    res->body() = std::move(body);
    res->prepare_payload();
    write(std::move(res));
  }

  void write(std::shared_ptr<http::response<http::string_body>> res) {
    const auto bytes = res->body().size();
    st_->ctx.stats.buffered_bytes += bytes;
    tcp_().expires_after(limits_.write_timeout);
    http::async_write(stream_, *res, [self = shared_from_this(), res, bytes](const error_code& ec, std::size_t) {
      self->st_->ctx.stats.buffered_bytes -= bytes;
      if (ec == beast::error::timeout) ++self->st_->ctx.stats.slow_readers;
      if (ec || !res->keep_alive()) return self->close();
      self->do_read();
    });
  }

  // An orderly end: over TLS a close_notify first (RFC 8446 §6.1), so that the peer knows the
  // last response was whole; waited for at most write_timeout.
  void close() {
    if constexpr (kTls) {
      tcp_().expires_after(limits_.write_timeout);
      stream_.async_shutdown([self = shared_from_this()](const error_code&) { self->close_now(); });
    } else {
      error_code ignored;
      tcp_().socket().shutdown(tcp::socket::shutdown_send, ignored);
      tcp_().close();
    }
  }

  static Principal as(Principal p, const char* transport) {
    p.transport = transport;
    return p;
  }

  Stream stream_;
  asio::any_io_executor ex_;  // the stream's, still there once a WebSocket took the stream
  bool upgraded_ = false;     // the stream went to a WebSocket session
  std::optional<Principal> certified_;  // by a client certificate (https://)
  std::shared_ptr<HttpState> st_;
  Limits limits_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  std::string peer_;
  std::string cors_origin_;  // a listed Origin of the current request: CORS headers
};

template <bool Tls>
class HttpListener final : public Listener, public std::enable_shared_from_this<HttpListener<Tls>> {
  using std::enable_shared_from_this<HttpListener<Tls>>::shared_from_this;
 public:
  HttpListener(asio::io_context& io, tcp::acceptor acceptor, std::string endpoint,
               std::shared_ptr<HttpState> st)
      : io_(io), acceptor_(std::move(acceptor)), backoff_(acceptor_.get_executor()),
        endpoint_(std::move(endpoint)), st_(std::move(st)) {}

  void accept() {
    acceptor_.async_accept(connection_executor(io_, st_->ctx), [self = shared_from_this()](const error_code& ec, tcp::socket s) {
      if (ec) {
        if (ec == asio::error::operation_aborted || !self->acceptor_.is_open()) return;
        self->backoff_.failed(ec, self->endpoint_, self->st_->ctx.stats.accept_backoffs,
                              [self] { self->accept(); });
        return;
      }
      self->backoff_.succeeded();
      ++self->st_->accepted;
      if (self->st_->connections.load() + self->st_->websockets.load() >=
          self->st_->ctx.limits.max_connections) {
        ++self->st_->dropped;
        error_code ignored;
        s.close(ignored);
      } else {
        ++self->st_->connections;
        error_code ignored;
        s.set_option(tcp::no_delay(true), ignored);  // a response is one write; see ndjson.cpp
        if constexpr (Tls)
          std::make_shared<HttpSession<beast::ssl_stream<beast::tcp_stream>>>(
              beast::ssl_stream<beast::tcp_stream>(beast::tcp_stream(std::move(s)), *self->st_->ctx.tls->current()),
              self->st_)
              ->start();
        else
          std::make_shared<HttpSession<beast::tcp_stream>>(beast::tcp_stream(std::move(s)), self->st_)->start();
      }
      self->accept();
    });
  }

  std::string endpoint() const override { return endpoint_; }

  void close() override {
    asio::post(acceptor_.get_executor(), [self = shared_from_this()] {
      error_code ignored;
      self->acceptor_.close(ignored);
      self->backoff_.cancel();
    });
    std::vector<std::pair<std::weak_ptr<void>, std::function<void()>>> closers;
    {
      std::lock_guard lock(st_->mu);
      closers.swap(st_->closers);
    }
    for (auto& c : closers) c.second();
  }

  void end_sessions_of(const std::string& name) override { st_->ws.end_sessions_of(name, st_->ctx.stats); }

  bool closing() const override { return st_->ending.load() > 0; }

  void write_stats(JsonWriter& w) const override {
    w.member("endpoint", endpoint_)
        .member("connections", st_->connections.load())
        .member("websockets", st_->websockets.load())
        .member("accepted", st_->accepted.load())
        .member("dropped", st_->dropped.load());
  }

 private:
  asio::io_context& io_;
  tcp::acceptor acceptor_;
  AcceptBackoff backoff_;
  std::string endpoint_;
  std::shared_ptr<HttpState> st_;
};

}  // namespace

std::shared_ptr<Listener> listen_http(asio::io_context& io, const std::string& host,
                                      std::uint16_t port, const Context& ctx) {
  auto [acceptor, name] = bind_tcp(io, "http", host, port);
  auto l = std::make_shared<HttpListener<false>>(io, std::move(acceptor), std::move(name),
                                                 std::make_shared<HttpState>(ctx, false));
  l->accept();
  return l;
}

std::shared_ptr<Listener> listen_https(asio::io_context& io, const std::string& host,
                                       std::uint16_t port, const Context& ctx) {
  if (!ctx.tls) throw Error::invalid("server.tls.cert", "an https:// listener needs [server.tls] cert and key");
  auto [acceptor, name] = bind_tcp(io, "https", host, port);
  auto l = std::make_shared<HttpListener<true>>(io, std::move(acceptor), std::move(name),
                                                std::make_shared<HttpState>(ctx, true));
  l->accept();
  return l;
}

}  // namespace gonio::daemon::net
