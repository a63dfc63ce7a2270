// The alert webhook: JSON POSTs with retries and exponential back-off (Boost.Beast client).
// One delivery at a time, in order; a bounded queue (the oldest payload is dropped, and
// counted as failed, when alerts come faster than the receiver takes them).
#include <atomic>
#include <deque>
#include <mutex>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/net/net.hpp"

#include "gonio/proto/version.hpp"

namespace gonio::daemon::net {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using boost::system::error_code;
using tcp = asio::ip::tcp;
using nlohmann::json;

namespace {

constexpr std::size_t kMaxPending = 1000;

struct Url {
  std::string host, port = "80", target = "/";
};

// http://HOST[:PORT][/PATH] (RFC 3986 authority; IPv6 literals in brackets).
Url parse_url(const std::string& url) {
  if (!url.starts_with("http://"))
    throw Error::invalid("webhook.url", fmt::format("'{}' must start with http://", url));
  std::string rest = url.substr(7);
  Url u;
  const auto slash = rest.find('/');
  if (slash != std::string::npos) {
    u.target = rest.substr(slash);
    rest = rest.substr(0, slash);
  }
  if (!rest.empty() && rest.front() == '[') {
    const auto close = rest.find(']');
    if (close == std::string::npos) throw Error::invalid("webhook.url", "unclosed '[' in the host");
    u.host = rest.substr(1, close - 1);
    if (close + 1 < rest.size() && rest[close + 1] == ':') u.port = rest.substr(close + 2);
  } else if (const auto colon = rest.rfind(':'); colon != std::string::npos) {
    u.host = rest.substr(0, colon);
    u.port = rest.substr(colon + 1);
  } else {
    u.host = rest;
  }
  if (u.host.empty()) throw Error::invalid("webhook.url", fmt::format("'{}' has no host", url));
  if (u.port.empty() || u.port.find_first_not_of("0123456789") != std::string::npos)
    throw Error::invalid("webhook.url", fmt::format("'{}' has a bad port", url));
  return u;
}

class Webhook final : public AlertSink, public std::enable_shared_from_this<Webhook> {
 public:
  Webhook(asio::io_context& io, const Config& c)
      : strand_(asio::make_strand(io)), resolver_(strand_), timer_(strand_), url_(parse_url(c.webhook_url)),
        text_(c.webhook_url), retries_(c.webhook_retries), backoff_(c.webhook_backoff),
        timeout_(c.webhook_timeout) {}

  void deliver(const json& payload) override {
    asio::post(strand_, [self = shared_from_this(), body = payload.dump()]() mutable {
      if (self->queue_.size() >= kMaxPending) {
        self->queue_.pop_front();
        ++self->failed_;
        spdlog::error("webhook {}: queue full, dropped the oldest alert", self->text_);
      }
      self->queue_.push_back(std::move(body));
      ++self->pending_;
      if (!self->busy_) self->next();
    });
  }

  json stats() const override {
    return json{{"url", text_}, {"delivered", delivered_.load()}, {"failed", failed_.load()},
                {"pending", pending_.load()}};
  }

 private:
  void next() {
    if (queue_.empty()) {
      busy_ = false;
      return;
    }
    busy_ = true;
    attempt_ = 0;
    try_once();
  }

  void try_once() {
    ++attempt_;
    resolver_.async_resolve(url_.host, url_.port, [self = shared_from_this()](
                                                      const error_code& ec, tcp::resolver::results_type r) {
      if (ec) return self->failed(ec.message());
      self->stream_.emplace(self->strand_);
      self->stream_->expires_after(self->timeout_);
      self->stream_->async_connect(r, [self](const error_code& ec2, const tcp::endpoint&) {
        if (ec2) return self->failed(ec2.message());
        self->send();
      });
    });
  }

  void send() {
    req_ = {};
    req_.method(http::verb::post);
    req_.target(url_.target);
    req_.version(11);
    req_.set(http::field::host, url_.host + ":" + url_.port);
    req_.set(http::field::user_agent, "goniod/" GONIO_VERSION_STRING);
    req_.set(http::field::content_type, "application/json");
    req_.keep_alive(false);
    req_.body() = queue_.front();
    req_.prepare_payload();
    stream_->expires_after(timeout_);
    http::async_write(*stream_, req_, [self = shared_from_this()](const error_code& ec, std::size_t) {
      if (ec) return self->failed(ec.message());
      self->res_.emplace();
      self->res_->body_limit(64 * 1024);  // the receiver's answer is only looked at for its status
      self->buffer_.clear();
      http::async_read(*self->stream_, self->buffer_, *self->res_, [self](const error_code& ec2, std::size_t) {
        if (ec2) return self->failed(ec2.message());
        const auto status = self->res_->get().result_int();
        self->shutdown();
        if (status >= 200 && status < 300) {
          ++self->delivered_;
          --self->pending_;
          self->queue_.pop_front();
          self->next();
        } else {
          self->failed(fmt::format("HTTP {}", status));
        }
      });
    });
  }

  void shutdown() {
    if (!stream_) return;
    error_code ignored;
    stream_->socket().shutdown(tcp::socket::shutdown_both, ignored);
    stream_->close();
  }

  void failed(const std::string& why) {
    shutdown();
    if (attempt_ > retries_) {
      spdlog::error("webhook {}: giving up after {} attempts: {}", text_, attempt_, why);
      ++failed_;
      --pending_;
      queue_.pop_front();
      next();
      return;
    }
    const auto delay = backoff_ * (1LL << std::min(attempt_ - 1, 10));
    spdlog::warn("webhook {}: attempt {} failed ({}); retrying in {} ms", text_, attempt_, why,
                 delay.count());
    timer_.expires_after(delay);
    timer_.async_wait([self = shared_from_this()](const error_code& ec) {
      if (!ec) self->try_once();
    });
  }

  asio::strand<asio::io_context::executor_type> strand_;
  tcp::resolver resolver_;
  asio::steady_timer timer_;
  std::optional<beast::tcp_stream> stream_;
  Url url_;
  std::string text_;
  int retries_;
  std::chrono::milliseconds backoff_, timeout_;
  std::deque<std::string> queue_;
  http::request<http::string_body> req_;
  std::optional<http::response_parser<http::string_body>> res_;
  beast::flat_buffer buffer_;
  bool busy_ = false;
  int attempt_ = 0;
  std::atomic<std::uint64_t> delivered_{0}, failed_{0}, pending_{0};
};

}  // namespace

std::shared_ptr<AlertSink> make_webhook(asio::io_context& io, const Config& config) {
  return std::make_shared<Webhook>(io, config);
}

}  // namespace gonio::daemon::net
