// WebSocket sessions (RFC 6455) via Boost.Beast, on the connections http.cpp upgrades at /ws.
#include "net/ws_session.hpp"

#include <algorithm>

#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <boost/beast/websocket.hpp>
#include <boost/beast/websocket/ssl.hpp>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace gonio::daemon::net {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using boost::system::error_code;

namespace {

// One JSON-RPC message a text frame. Its queue, deadlines and slow-reader rule are
// StreamSession's; here, reading frames, writing one message a frame and the closing
// handshake. `Stream`: beast::tcp_stream, or beast::ssl_stream over it (wss://).
template <class Stream>
class WsSession final : public StreamSession {
 public:
  WsSession(Stream stream, std::string peer, std::shared_ptr<HttpState> st)
      : StreamSession(st->ws_transport(), std::move(peer), st->ctx, stream.get_executor(), 0),
        ws_(std::move(stream)), read_timer_(executor_), st_(std::move(st)) {
    ++st_->websockets;
  }
  ~WsSession() override { --st_->websockets; }

  void start(UpgradeRequest req) {
    auto timeouts = websocket::stream_base::timeout::suggested(beast::role_type::server);
    timeouts.handshake_timeout = limits_.read_timeout;
    if (limits_.idle_timeout.count() > 0) timeouts.idle_timeout = limits_.idle_timeout;
    timeouts.keep_alive_pings = true;
    ws_.set_option(timeouts);
    ws_.read_message_max(limits_.max_message_bytes);
    ws_.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& res) { res.set(http::field::server, "goniod"); }));
    auto me = self();
    st_->add_closer(me, [w = std::weak_ptr<WsSession>(me)] {
      auto s = w.lock();
      if (!s) return;
      ++s->st_->ending;  // counted before it runs: shutdown waits for it
      asio::post(s->executor_, [s] { s->going_away(); });
    });
    st_->ws.add(me);
    start_login_deadline();
    ws_.async_accept(req, [me](const error_code& ec) {
      if (ec) {
        me->close(ec.message());
        return;
      }
      me->ws_.text(true);
      me->do_read();
    });
  }

 private:
  std::shared_ptr<WsSession> self() { return std::static_pointer_cast<WsSession>(shared_from_this()); }

  // The server is stopping: a Close frame with 1001, "going away" (RFC 6455 §7.4.1), then
  // the peer's own Close is read and Beast's teardown ends the TCP connection. Ending it
  // without the handshake could leave the peer's last frames unread, and closing a socket
  // with unread data resets it: a browser reports a reset connection as an error, a clean
  // close as a reason to reconnect.
  void going_away() {
    if (closed_ || close_sent_ || !ws_.is_open()) {
      close("the server is stopping");
      --st_->ending;
      return;
    }
    close_sent_ = true;
    cancel_login_deadline();
    read_timer_.cancel();
    ws_.async_close(websocket::close_reason(websocket::close_code::going_away, "the server is stopping"),
                    [self = self()](const error_code& ec) {
                      self->close(ec ? ec.message() : "the server is stopping");
                      --self->st_->ending;
                    });
  }

  bool may_read() const {
    return !closed_ && !close_sent_ && in_flight_ < limits_.max_in_flight && !out_.backed_up();
  }

  // Frames are read one at a time so that a message that has started must complete within
  // read_timeout, as on NDJSON (Beast's own timeouts only cover idle peers).
  void do_read() {
    if (reading_ || !may_read()) return;
    reading_ = true;
    ws_.async_read_some(buffer_, limits_.max_message_bytes, [self = self()](const error_code& ec, std::size_t) {
      self->reading_ = false;
      self->on_read(ec);
    });
  }

  void on_read(const error_code& ec) {
    // Closing: a request that came before the peer's Close frame goes unanswered, and the
    // close operation ends the session.
    if (closed_ || close_sent_) return;
    if (ec) {
      if (ec == websocket::error::message_too_big) {
        ++st_->dropped;
        spdlog::warn("{} {}: message larger than {} bytes; closing", transport(), peer(),
                     limits_.max_message_bytes);
      }
      close(ec == websocket::error::closed ? "" : ec.message());
      return;
    }
    if (!ws_.is_message_done()) {
      if (!message_started_) {
        message_started_ = true;
        read_timer_.expires_after(limits_.read_timeout);
        read_timer_.async_wait([self = self()](const error_code& e) {
          if (e || self->closed_ || !self->message_started_) return;
          self->close("read timeout (message never completed)");
        });
      }
      do_read();
      return;
    }
    message_started_ = false;
    read_timer_.cancel();
    std::string text = beast::buffers_to_string(buffer_.data());
    buffer_.consume(buffer_.size());
    buffer_.shrink_to_fit();
    auto weight = std::make_shared<std::size_t>(1);
    const auto w = st_->ctx.dispatcher.handle(text, shared_from_this(), [self = self(), weight](std::string r) {
      asio::post(self->executor_, [self, weight, r = self->admit_reply(std::move(r))]() mutable {
        self->on_reply(std::move(r), *weight);
        self->do_read();
      });
    });
    *weight = w;  // before the posted reply can run: both are on this strand
    in_flight_ += w;
    do_read();
  }

  void write_queued() override {
    if (writing_ || out_.empty() || closed_ || close_sent_) return;
    write_started();
    ws_.async_write(asio::buffer(*out_[0]), [self = self()](const error_code& ec, std::size_t) {
      if (!self->write_ended(ec, 1)) return;
      self->write_queued();
      self->do_read();
    });
  }

  void close(const std::string& why) override {
    if (!mark_closed(why)) return;
    read_timer_.cancel();
    error_code ignored;
    beast::get_lowest_layer(ws_).socket().shutdown(asio::ip::tcp::socket::shutdown_both, ignored);
    beast::get_lowest_layer(ws_).close();
  }

  websocket::stream<Stream> ws_;
  asio::steady_timer read_timer_;
  std::shared_ptr<HttpState> st_;
  beast::flat_buffer buffer_;
  bool reading_ = false, message_started_ = false;
  bool close_sent_ = false;  // our Close frame is sent or on its way: nothing else is written
};

template <class Stream>
void start(Stream stream, std::string peer, std::shared_ptr<HttpState> st, std::optional<Principal> who,
           UpgradeRequest req) {
  auto ws = std::make_shared<WsSession<Stream>>(std::move(stream), std::move(peer), std::move(st));
  if (who) ws->set_principal(std::move(*who));
  ws->start(std::move(req));
}

}  // namespace

void start_websocket(beast::tcp_stream stream, std::string peer, std::shared_ptr<HttpState> st,
                     std::optional<Principal> who, UpgradeRequest req) {
  start(std::move(stream), std::move(peer), std::move(st), std::move(who), std::move(req));
}

void start_websocket(beast::ssl_stream<beast::tcp_stream> stream, std::string peer,
                     std::shared_ptr<HttpState> st, std::optional<Principal> who, UpgradeRequest req) {
  start(std::move(stream), std::move(peer), std::move(st), std::move(who), std::move(req));
}

}  // namespace gonio::daemon::net
