// What every listener shares (session.hpp), and the limits and counters of net.hpp.
#include "net/session.hpp"

#include <unistd.h>

#include <algorithm>

#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/proto/error.hpp"

namespace gonio::daemon::net {

namespace asio = boost::asio;
using nlohmann::json;

Limits Limits::from(const Config& c) {
  Limits l;
  l.max_message_bytes = c.max_message_bytes;
  l.read_timeout = c.read_timeout;
  l.idle_timeout = c.idle_timeout;
  l.max_queue = c.max_queue;
  l.max_connections = c.max_connections;
  l.max_queue_bytes = c.max_queue_bytes;
  l.max_buffered_bytes = c.max_buffered_bytes;
  l.write_timeout = c.write_timeout;
  l.login_timeout = c.login_timeout;
  l.max_in_flight = c.max_in_flight;
  l.allowed_origins = c.allowed_origins;
  const auto& u = c.unix_roles;
  l.admin_uids = u.admin_uids.value_or(std::vector<std::uint32_t>{0, ::geteuid()});
  l.admin_gids = u.admin_gids.value_or(std::vector<std::uint32_t>{});
  l.technician_uids = u.technician_uids.value_or(std::vector<std::uint32_t>{});
  l.technician_gids = u.technician_gids.value_or(std::vector<std::uint32_t>{::getegid()});
  l.viewer_uids = u.viewer_uids.value_or(std::vector<std::uint32_t>{});
  l.viewer_gids = u.viewer_gids.value_or(std::vector<std::uint32_t>{});
  return l;
}

void NetStats::write(JsonWriter& w) const {
  w.member("buffered_bytes", buffered_bytes.load())
      .member("slow_readers_dropped", slow_readers.load())
      .member("login_timeouts", login_timeouts.load())
      .member("refused_origin", refused_origin.load())
      .member("refused_content_type", refused_content_type.load())
      .member("accept_backoffs", accept_backoffs.load())
      .member("overload_dropped", overload_dropped.load())
      .member("revoked_sessions_ended", revoked_sessions.load());
}

bool OutputQueue::admit(const std::string& m, std::size_t extra_messages) {
  const auto bytes = size_of(m);
  if (queued_.fetch_add(1) + 1 > limits_.max_queue + extra_messages) {
    --queued_;
    return false;
  }
  const auto mine = queued_bytes_.fetch_add(bytes) + bytes;
  const auto all = stats_.buffered_bytes.fetch_add(bytes) + bytes;
  // A connection with nothing queued may always have one message of a modest size, so
  // that a flood elsewhere cannot starve it of small answers.
  const bool first_small = mine == bytes && bytes <= kReadPauseBytes;
  if (mine > limits_.max_queue_bytes || (all > limits_.max_buffered_bytes && !first_small)) {
    release(bytes);
    return false;
  }
  return true;
}

bool OutputQueue::add(Message m, bool admitted) {
  // An answer may find the queue full of notifications: it has max_in_flight more places.
  if (!admitted && !admit(*m, limits_.max_in_flight)) return false;
  out_.push_back(std::move(m));
  return true;
}

void OutputQueue::pop(std::size_t n) {
  for (; n > 0 && !out_.empty(); --n) {
    release(size_of(*out_.front()));
    out_.pop_front();
  }
}

void OutputQueue::release(std::size_t bytes) {
  --queued_;
  queued_bytes_ -= bytes;
  stats_.buffered_bytes -= bytes;
}

std::string WriteDeadline::late_message() const {
  return fmt::format("a write did not complete within {} s (the peer does not read)",
                     std::chrono::duration<double>(timeout_).count());
}

StreamSession::StreamSession(std::string transport, std::string peer, const Context& ctx,
                             asio::any_io_executor executor, std::size_t framing)
    : rpc::Session(std::move(transport), std::move(peer), true), executor_(std::move(executor)),
      limits_(ctx.limits), stats_(ctx.stats), out_(limits_, stats_, framing), hub_(ctx.hub),
      write_deadline_(executor_, limits_.write_timeout), login_timer_(executor_) {}

bool StreamSession::push(std::shared_ptr<const std::string> message) {
  if (refusing_.load()) return false;
  if (!out_.admit(*message)) {
    asio::post(executor_, [self = shared_from_this()] {
      self->slow_reader("its outgoing queue is full (the peer does not read)");
    });
    return false;
  }
  asio::post(executor_, [self = shared_from_this(), m = std::move(message)] { self->enqueue(m, true); });
  return true;
}

void StreamSession::end(std::string why) {
  asio::post(executor_, [self = shared_from_this(), why = std::move(why)] { self->close(why); });
}

void StreamSession::start_login_deadline() {
  if (principal().role != Role::none) return;
  login_timer_.expires_after(limits_.login_timeout);
  login_timer_.async_wait([self = shared_from_this()](const boost::system::error_code& ec) {
    if (ec || self->closed_ || self->principal().role != Role::none) return;
    ++self->stats_.login_timeouts;
    self->close(fmt::format("did not log in within {} s",
                            std::chrono::duration<double>(self->limits_.login_timeout).count()));
  });
}

void StreamSession::enqueue(OutputQueue::Message m, bool admitted) {
  if (closed_) {
    if (admitted) out_.forget(m);
    return;
  }
  if (!out_.add(std::move(m), admitted)) {
    slow_reader("its outgoing queue is full (the peer does not read its answers)");
    return;
  }
  write_queued();
}

void StreamSession::on_reply(std::string reply, std::size_t weight) {
  in_flight_ -= std::min(in_flight_, weight);
  if (!reply.empty()) enqueue(std::make_shared<const std::string>(std::move(reply)), false);
}

StreamSession::AdmittedReply StreamSession::admit_reply(std::string reply) {
  if (reply.empty()) return {};
  auto m = std::make_shared<const std::string>(std::move(reply));
  const bool admitted = !refusing_.load() && out_.admit(*m, limits_.max_in_flight);
  return {std::move(m), admitted};
}

void StreamSession::on_reply(AdmittedReply reply, std::size_t weight) {
  in_flight_ -= std::min(in_flight_, weight);
  if (!reply.message) return;
  if (!reply.admitted) {
    slow_reader("its outgoing queue is full (the peer does not read its answers)");
    return;
  }
  enqueue(std::move(reply.message), true);
}

void StreamSession::write_started() {
  writing_ = true;
  write_deadline_.started([self = shared_from_this()] { return !self->closed_ && self->writing_; },
                          [self = shared_from_this()](const std::string& why) { self->slow_reader(why); });
}

bool StreamSession::write_ended(const boost::system::error_code& ec, std::size_t n) {
  writing_ = false;
  if (closed_) return false;
  out_.pop(n);
  if (ec) {
    close(ec.message());
    return false;
  }
  return true;
}

bool StreamSession::mark_closed(const std::string& why) {
  if (closed_) return false;
  closed_ = true;
  refusing_ = true;
  mark_gone();
  if (!why.empty()) spdlog::info("{} {}: closing: {}", transport(), peer(), why);
  write_deadline_.cancel();
  login_timer_.cancel();
  hub_.remove(id());
  // What is queued is freed now, not when the last handler lets go of the session.
  if (!writing_) out_.pop(out_.size());
  return true;
}

void StreamSession::slow_reader(const std::string& why) {
  if (closed_) return;
  ++stats_.slow_readers;
  close(why);
}

void SessionList::add(const std::shared_ptr<StreamSession>& session) {
  std::lock_guard lock(mu_);
  std::erase_if(sessions_, [](const auto& w) { return w.expired(); });
  sessions_.push_back(session);
}

std::vector<std::shared_ptr<StreamSession>> SessionList::take() {
  std::vector<std::weak_ptr<StreamSession>> all;
  {
    std::lock_guard lock(mu_);
    all.swap(sessions_);
  }
  std::vector<std::shared_ptr<StreamSession>> live;
  for (auto& w : all)
    if (auto s = w.lock()) live.push_back(std::move(s));
  return live;
}

void SessionList::end_sessions_of(const std::string& name, NetStats& stats) {
  std::vector<std::shared_ptr<StreamSession>> live;
  {
    std::lock_guard lock(mu_);
    for (auto& w : sessions_)
      if (auto s = w.lock()) live.push_back(std::move(s));
  }
  for (auto& s : live) {
    const auto p = s->principal();
    if (p.role == Role::none || p.name != name) continue;
    ++stats.revoked_sessions;
    s->end(fmt::format("the token '{}' was revoked", name));
  }
}

Role unix_role(const Limits& l, std::uint32_t uid, const std::vector<gid_t>& gids) {
  const auto has = [](const std::vector<std::uint32_t>& v, std::uint32_t x) {
    return std::find(v.begin(), v.end(), x) != v.end();
  };
  const auto any_gid = [&](const std::vector<std::uint32_t>& v) {
    return std::any_of(gids.begin(), gids.end(), [&](gid_t g) { return has(v, g); });
  };
  if (has(l.admin_uids, uid) || any_gid(l.admin_gids)) return Role::admin;
  if (has(l.technician_uids, uid) || any_gid(l.technician_gids)) return Role::technician;
  if (has(l.viewer_uids, uid) || any_gid(l.viewer_gids)) return Role::viewer;
  return Role::none;
}

BoundTcp bind_tcp(asio::io_context& io, std::string_view scheme, const std::string& host,
                  std::uint16_t port) {
  using tcp = asio::ip::tcp;
  boost::system::error_code ec;
  const auto addr = asio::ip::make_address(host == "localhost" ? "127.0.0.1" : host, ec);
  if (ec) throw Error(Errc::invalid_argument, fmt::format("{}://{}: {}", scheme, host, ec.message()));
  tcp::acceptor acceptor(io);
  const tcp::endpoint ep(addr, port);
  acceptor.open(ep.protocol(), ec);
  if (!ec) acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) acceptor.bind(ep, ec);
  if (!ec) acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec)
    throw Error(Errc::io_error,
                fmt::format("cannot listen on {}://{}:{}: {}", scheme, host, port, ec.message()));
  const auto bound = acceptor.local_endpoint();
  const auto a = bound.address().to_string();
  auto endpoint = fmt::format("{}://{}:{}", scheme, bound.address().is_v6() ? "[" + a + "]" : a,
                              bound.port());
  return {std::move(acceptor), std::move(endpoint)};
}

}  // namespace gonio::daemon::net
