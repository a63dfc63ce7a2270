// HTTP POST /rpc and WebSocket /ws via Boost.Beast (see net.hpp).
#include <atomic>
#include <deque>
#include <mutex>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/net.hpp"

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

struct HttpState {
  Context ctx;
  std::atomic<std::size_t> connections{0}, accepted{0}, dropped{0}, websockets{0};
  std::mutex mu;
  // Who to close on shutdown; expired entries are pruned as new ones arrive.
  std::vector<std::pair<std::weak_ptr<void>, std::function<void()>>> closers;
  explicit HttpState(const Context& c) : ctx(c) {}
  void add_closer(std::weak_ptr<void> owner, std::function<void()> f) {
    std::lock_guard lock(mu);
    std::erase_if(closers, [](const auto& c) { return c.first.expired(); });
    closers.emplace_back(std::move(owner), std::move(f));
  }
};

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

std::string error_body(int code, std::string_view msg, Errc errc) {
  return json{{"jsonrpc", "2.0"}, {"error", rpc::error_object(code, msg, errc)}, {"id", nullptr}}.dump();
}

// A request over HTTP POST: no notifications can reach it.
class OneShot final : public rpc::Session {
 public:
  OneShot(std::string peer, Principal p) : rpc::Session("http", std::move(peer), false) {
    set_principal(std::move(p));
  }
  bool push(std::shared_ptr<const std::string>) override { return false; }
};

// ---- WebSocket ----------------------------------------------------------------------------

class WsSession final : public rpc::Session, public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(tcp::socket socket, std::string peer, std::shared_ptr<HttpState> st)
      : rpc::Session("ws", std::move(peer), true), ws_(std::move(socket)), st_(std::move(st)),
        limits_(st_->ctx.limits) {
    ++st_->websockets;
  }
  ~WsSession() override { --st_->websockets; }

  void start(http::request<http::string_body> req) {
    auto timeouts = websocket::stream_base::timeout::suggested(beast::role_type::server);
    timeouts.handshake_timeout = limits_.read_timeout;
    if (limits_.idle_timeout.count() > 0) timeouts.idle_timeout = limits_.idle_timeout;
    timeouts.keep_alive_pings = true;
    ws_.set_option(timeouts);
    ws_.read_message_max(limits_.max_message_bytes);
    ws_.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& res) { res.set(http::field::server, "goniod"); }));
    auto self = shared_from_this();
    st_->add_closer(self, [w = std::weak_ptr<WsSession>(self)] {
      if (auto s = w.lock()) asio::post(s->ws_.get_executor(), [s] { s->close("the server is stopping"); });
    });
    ws_.async_accept(req, [self](const error_code& ec) {
      if (ec) {
        self->close(ec.message());
        return;
      }
      self->ws_.text(true);
      self->do_read();
    });
  }

  bool push(std::shared_ptr<const std::string> message) override {
    if (closed_flag_.load()) return false;
    if (queued_.fetch_add(1) + 1 > limits_.max_queue) {
      --queued_;
      ++st_->dropped;
      asio::post(ws_.get_executor(), [self = shared_from_this()] {
        self->close("its outgoing queue is full (the peer does not read)");
      });
      return false;
    }
    asio::post(ws_.get_executor(), [self = shared_from_this(), m = std::move(message)] {
      self->enqueue(m, true);
    });
    return true;
  }

 private:
  void do_read() {
    if (reading_ || closed_ || in_flight_ >= limits_.max_in_flight) return;
    reading_ = true;
    ws_.async_read(buffer_, [self = shared_from_this()](const error_code& ec, std::size_t) {
      self->reading_ = false;
      if (self->closed_) return;
      if (ec) {
        if (ec == websocket::error::message_too_big) {
          ++self->st_->dropped;
          spdlog::warn("ws {}: message larger than {} bytes; closing", self->peer(),
                       self->limits_.max_message_bytes);
        }
        self->close(ec == websocket::error::closed ? "" : ec.message());
        return;
      }
      std::string text = beast::buffers_to_string(self->buffer_.data());
      self->buffer_.consume(self->buffer_.size());
      ++self->in_flight_;
      self->st_->ctx.dispatcher.handle(text, self, [self](std::string r) {
        asio::post(self->ws_.get_executor(), [self, r = std::move(r)]() mutable {
          --self->in_flight_;
          if (!r.empty()) self->enqueue(std::make_shared<const std::string>(std::move(r)), false);
          self->do_read();
        });
      });
      self->do_read();
    });
  }

  void enqueue(std::shared_ptr<const std::string> m, bool counted) {
    if (closed_) {
      if (counted) --queued_;
      return;
    }
    if (!counted && queued_.fetch_add(1) + 1 > limits_.max_queue + limits_.max_in_flight) {
      --queued_;
      close("its outgoing queue is full (the peer does not read)");
      return;
    }
    out_.push_back(std::move(m));
    do_write();
  }

  void do_write() {
    if (writing_ || out_.empty() || closed_) return;
    writing_ = true;
    ws_.async_write(asio::buffer(*out_.front()), [self = shared_from_this()](const error_code& ec, std::size_t) {
      self->writing_ = false;
      if (self->closed_) return;
      self->out_.pop_front();
      --self->queued_;
      if (ec) {
        self->close(ec.message());
        return;
      }
      self->do_write();
    });
  }

  void close(const std::string& why) {
    if (closed_) return;
    closed_ = true;
    closed_flag_ = true;
    if (!why.empty()) spdlog::info("ws {}: closing: {}", peer(), why);
    st_->ctx.hub.remove(id());
    error_code ignored;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ignored);
    beast::get_lowest_layer(ws_).close();
  }

  websocket::stream<beast::tcp_stream> ws_;
  std::shared_ptr<HttpState> st_;
  Limits limits_;
  beast::flat_buffer buffer_;
  std::deque<std::shared_ptr<const std::string>> out_;
  std::atomic<std::size_t> queued_{0};
  std::atomic<bool> closed_flag_{false};
  bool reading_ = false, writing_ = false, closed_ = false;
  std::size_t in_flight_ = 0;
};

// ---- HTTP ---------------------------------------------------------------------------------

class HttpSession final : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket socket, std::shared_ptr<HttpState> st)
      : stream_(std::move(socket)), st_(std::move(st)), limits_(st_->ctx.limits) {
    error_code ec;
    const auto ep = stream_.socket().remote_endpoint(ec);
    peer_ = ec ? "?" : fmt::format("{}:{}", ep.address().to_string(), ep.port());
  }
  ~HttpSession() { --st_->connections; }

  void start() {
    auto self = shared_from_this();
    st_->add_closer(self, [w = std::weak_ptr<HttpSession>(self)] {
      if (auto s = w.lock())
        asio::post(s->stream_.get_executor(), [s] {
          error_code ignored;
          s->stream_.socket().shutdown(tcp::socket::shutdown_both, ignored);
          s->stream_.close();
        });
    });
    do_read();
  }

 private:
  void do_read() {
    parser_.emplace();
    parser_->body_limit(limits_.max_message_bytes);
    parser_->header_limit(kHeaderLimit);
    // One deadline for the whole request (a keep-alive connection waits at most this long
    // for the next one).
    stream_.expires_after(limits_.read_timeout);
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
    const auto token = bearer(req[http::field::authorization]);
    std::optional<Principal> who;
    if (!token.empty()) {
      who = st_->ctx.auth.authenticate(token, websocket::is_upgrade(req) ? "ws" : "http");
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
      stream_.expires_never();
      auto ws = std::make_shared<WsSession>(stream_.release_socket(), peer_, st_);
      if (who) ws->set_principal(*who);
      ws->start(std::move(req));
      return;
    }
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
    Principal p;
    p.transport = "http";
    p.name = "anonymous";
    if (who) p = *who;
    auto session = std::make_shared<OneShot>(peer_, p);
    const bool keep = req.keep_alive();
    const unsigned version = req.version();
    st_->ctx.dispatcher.handle(req.body(), session, [self = shared_from_this(), keep, version](std::string r) {
      asio::post(self->stream_.get_executor(), [self, keep, version, r = std::move(r)]() mutable {
        if (r.empty()) self->send(http::status::no_content, {}, keep, version);
        else self->send(http::status::ok, std::move(r), keep, version);
      });
    });
  }

  void send(http::status status, std::string body, bool keep_alive, unsigned version,
            bool challenge = false, const char* allow = nullptr) {
    auto res = std::make_shared<http::response<http::string_body>>(status, version);
    res->set(http::field::server, "goniod");
    if (!body.empty()) res->set(http::field::content_type, "application/json");
    if (challenge) res->set(http::field::www_authenticate, "Bearer realm=\"goniod\"");
    if (allow) res->set(http::field::allow, allow);
    res->keep_alive(keep_alive);
    res->body() = std::move(body);
    res->prepare_payload();
    stream_.expires_after(limits_.read_timeout);
    http::async_write(stream_, *res, [self = shared_from_this(), res](const error_code& ec, std::size_t) {
      if (ec || !res->keep_alive()) return self->close();
      self->do_read();
    });
  }

  void close() {
    error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
    stream_.close();
  }

  beast::tcp_stream stream_;
  std::shared_ptr<HttpState> st_;
  Limits limits_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  std::string peer_;
};

class HttpListener final : public Listener, public std::enable_shared_from_this<HttpListener> {
 public:
  HttpListener(asio::io_context& io, tcp::acceptor acceptor, std::string endpoint,
               std::shared_ptr<HttpState> st)
      : io_(io), acceptor_(std::move(acceptor)), endpoint_(std::move(endpoint)), st_(std::move(st)) {}

  void accept() {
    acceptor_.async_accept(asio::make_strand(io_), [self = shared_from_this()](const error_code& ec, tcp::socket s) {
      if (ec) {
        if (ec != asio::error::operation_aborted) {
          spdlog::warn("{}: accept: {}", self->endpoint_, ec.message());
          self->accept();
        }
        return;
      }
      ++self->st_->accepted;
      if (self->st_->connections.load() + self->st_->websockets.load() >=
          self->st_->ctx.limits.max_connections) {
        ++self->st_->dropped;
        error_code ignored;
        s.close(ignored);
      } else {
        ++self->st_->connections;
        error_code ignored;
        s.set_option(tcp::no_delay(true), ignored);  // a response is one write; see net_ndjson.cpp
        std::make_shared<HttpSession>(std::move(s), self->st_)->start();
      }
      self->accept();
    });
  }

  std::string endpoint() const override { return endpoint_; }

  void close() override {
    asio::post(acceptor_.get_executor(), [self = shared_from_this()] {
      error_code ignored;
      self->acceptor_.close(ignored);
    });
    std::vector<std::pair<std::weak_ptr<void>, std::function<void()>>> closers;
    {
      std::lock_guard lock(st_->mu);
      closers.swap(st_->closers);
    }
    for (auto& c : closers) c.second();
  }

  json stats() const override {
    return json{{"endpoint", endpoint_},
                {"connections", st_->connections.load()},
                {"websockets", st_->websockets.load()},
                {"accepted", st_->accepted.load()},
                {"dropped", st_->dropped.load()}};
  }

 private:
  asio::io_context& io_;
  tcp::acceptor acceptor_;
  std::string endpoint_;
  std::shared_ptr<HttpState> st_;
};

}  // namespace

std::shared_ptr<Listener> listen_http(asio::io_context& io, const std::string& host,
                                      std::uint16_t port, const Context& ctx) {
  error_code ec;
  const auto addr = asio::ip::make_address(host == "localhost" ? "127.0.0.1" : host, ec);
  if (ec) throw Error(Errc::invalid_argument, fmt::format("http://{}: {}", host, ec.message()));
  tcp::acceptor acceptor(io);
  const tcp::endpoint ep(addr, port);
  acceptor.open(ep.protocol(), ec);
  if (!ec) acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) acceptor.bind(ep, ec);
  if (!ec) acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec)
    throw Error(Errc::io_error,
                fmt::format("cannot listen on http://{}:{}: {}", host, port, ec.message()));
  const auto bound = acceptor.local_endpoint();
  const auto a = bound.address().to_string();
  auto l = std::make_shared<HttpListener>(
      io, std::move(acceptor),
      fmt::format("http://{}:{}", bound.address().is_v6() ? "[" + a + "]" : a, bound.port()),
      std::make_shared<HttpState>(ctx));
  l->accept();
  return l;
}

}  // namespace gonio::daemon::net
