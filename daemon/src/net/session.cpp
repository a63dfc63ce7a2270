// What every listener shares (session.hpp), and the limits and counters of net.hpp.
#include "net/session.hpp"

#include <unistd.h>

#include <algorithm>

#include <boost/asio/io_context.hpp>
#include <fmt/format.h>

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
