// What every listener's sessions share (ndjson.cpp, http.cpp, ws_session.cpp): the outgoing
// queue of a connection with its limits, the write deadline, the session of a connection that
// carries notifications, the role of a Unix-socket peer, and binding a TCP address.
#pragma once

#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>

#include "gonio/daemon/net/net.hpp"

namespace gonio::daemon::net {

// A connection's messages waiting to go out, counted against its own limits (max_queue,
// max_queue_bytes) and against the budget all connections share (max_buffered_bytes). A
// message is admitted before it is queued: push() from any thread reserves its room, the
// strand then queues it; a peer whose message finds no room is dropped as a slow reader.
class OutputQueue {
 public:
  using Message = std::shared_ptr<const std::string>;

  // `framing`: bytes the transport adds to each message (the NDJSON newline).
  OutputQueue(const Limits& limits, NetStats& stats, std::size_t framing)
      : limits_(limits), stats_(stats), framing_(framing) {}
  ~OutputQueue() { stats_.buffered_bytes -= queued_bytes_.load(); }
  OutputQueue(const OutputQueue&) = delete;
  OutputQueue& operator=(const OutputQueue&) = delete;

  // Reserves room for `m` (any thread): false when the queue would pass max_queue
  // (+ `extra_messages`) or max_queue_bytes, or all connections max_buffered_bytes.
  bool admit(const std::string& m, std::size_t extra_messages = 0);
  // On the strand: queues `m`, reserving its room first unless push() did (`admitted`).
  // False when there is no room.
  bool add(Message m, bool admitted);
  // Gives back the room of a message that will not be queued after all.
  void forget(const Message& m) { release(size_of(*m)); }

  bool empty() const { return out_.empty(); }
  std::size_t size() const { return out_.size(); }
  const Message& operator[](std::size_t i) const { return out_[i]; }
  // The first `n` messages have been written (or will never be).
  void pop(std::size_t n);
  // Reading pauses while this much waits to go out.
  bool backed_up() const { return queued_bytes_.load() > kReadPauseBytes; }

 private:
  std::size_t size_of(const std::string& m) const { return m.size() + framing_; }
  void release(std::size_t bytes);

  const Limits& limits_;
  NetStats& stats_;
  std::size_t framing_;
  std::deque<Message> out_;
  std::atomic<std::size_t> queued_{0}, queued_bytes_{0};
};

// Every write must complete within write_timeout. One timer, armed when a write starts and
// none is pending, that re-arms itself while writes keep completing (most complete at once:
// arming and cancelling a timer for each would cost more than the write).
class WriteDeadline {
 public:
  using Clock = std::chrono::steady_clock;
  WriteDeadline(boost::asio::any_io_executor ex, std::chrono::milliseconds timeout)
      : timer_(std::move(ex)), timeout_(timeout) {}

  // As a write starts. `writing()` says whether one is still in progress; `late(why)` runs
  // when one has taken longer than the timeout. Both keep their session alive.
  template <class Writing, class Late>
  void started(Writing writing, Late late) {
    started_ = Clock::now();
    arm(std::move(writing), std::move(late));
  }
  void cancel() { timer_.cancel(); }

 private:
  template <class Writing, class Late>
  void arm(Writing writing, Late late) {
    if (armed_) return;
    armed_ = true;
    timer_.expires_at(started_ + timeout_);
    timer_.async_wait([this, writing, late](const boost::system::error_code& ec) mutable {
      armed_ = false;
      if (ec || !writing()) return;
      if (Clock::now() - started_ < timeout_) {
        arm(std::move(writing), std::move(late));  // a later write: its own deadline
        return;
      }
      late(late_message());
    });
  }
  std::string late_message() const;

  boost::asio::steady_timer timer_;
  std::chrono::milliseconds timeout_;
  Clock::time_point started_;
  bool armed_ = false;
};

// A connection that carries a JSON-RPC session and its notifications, NDJSON lines or
// WebSocket messages: what such a session does the same way whatever its stream (plain TCP,
// a Unix socket, TLS) and framing. The transports (ndjson.cpp's NdjsonSession,
// ws_session.cpp's WsSession) read, write and close their stream. Every handler runs on one
// strand, `executor`; push() and end() may be called from any thread.
class StreamSession : public rpc::Session, public std::enable_shared_from_this<StreamSession> {
 public:
  // `framing`: bytes the transport adds to each message (OutputQueue).
  StreamSession(std::string transport, std::string peer, const Context& ctx,
                boost::asio::any_io_executor executor, std::size_t framing);

  // Admits the message, then queues it on the strand. One that finds no room drops the peer
  // as a slow reader.
  bool push(std::shared_ptr<const std::string> message) final;
  // The session closes on the strand, saying why (its token was revoked).
  void end(std::string why);

 protected:
  // The transport's part, on the strand: start writing what is queued unless a write is on;
  // close the connection (once; `why` empty: an orderly end, not logged).
  virtual void write_queued() = 0;
  virtual void close(const std::string& why) = 0;

  // A peer without a role can only log in: it gets login_timeout to do so.
  void start_login_deadline();
  void cancel_login_deadline() { login_timer_.cancel(); }
  // Queues `m` and writes; `admitted`: push() has reserved its room.
  void enqueue(OutputQueue::Message m, bool admitted);
  // The reply to requests that weigh `weight` (a batch: its elements) is back; empty: nothing
  // to send (notifications only).
  void on_reply(std::string reply, std::size_t weight);
  // A reply that comes back on another thread (a worker) is admitted to the output budget
  // there, before it waits for the strand: answers waiting for a busy io thread count
  // against server.max_buffered_bytes like those queued. Then on the strand, on_reply.
  struct AdmittedReply {
    OutputQueue::Message message;  // null: nothing to send
    bool admitted = false;
  };
  AdmittedReply admit_reply(std::string reply);
  void on_reply(AdmittedReply reply, std::size_t weight);
  // A write is starting: it has write_timeout to complete.
  void write_started();
  // The write of the first `n` queued messages ended: false when the session is closed (or
  // closes now, on an error).
  bool write_ended(const boost::system::error_code& ec, std::size_t n);
  // What every close() does first: false when the session was closed already. Logs `why`,
  // stops the deadlines, leaves the hub and frees the queue unless a write holds it.
  bool mark_closed(const std::string& why);
  // The queue is full or a write missed its deadline: the peer does not read.
  void slow_reader(const std::string& why);

  boost::asio::any_io_executor executor_;
  const Limits limits_;
  NetStats& stats_;
  OutputQueue out_;
  bool closed_ = false, writing_ = false;
  std::size_t in_flight_ = 0;  // requests (batch elements) being processed

 private:
  Hub& hub_;
  WriteDeadline write_deadline_;
  boost::asio::steady_timer login_timer_;
  std::atomic<bool> refusing_{false};  // closed_, as push() on any thread sees it
};

// The live sessions of a listener: for ending those of a revoked token, and all on shutdown.
class SessionList {
 public:
  // Forgets the sessions that have ended meanwhile.
  void add(const std::shared_ptr<StreamSession>& session);
  // The live sessions, and the list emptied (the listener is closing).
  std::vector<std::shared_ptr<StreamSession>> take();
  // Ends every live session logged in with the token `name`, counting each in
  // stats.revoked_sessions.
  void end_sessions_of(const std::string& name, NetStats& stats);

 private:
  std::mutex mu_;
  std::vector<std::weak_ptr<StreamSession>> sessions_;
};

// The role of a Unix-socket peer from its uid and groups: the highest any of them maps to.
Role unix_role(const Limits& l, std::uint32_t uid, const std::vector<gid_t>& gids);

// An acceptor listening on HOST:PORT ("localhost" is 127.0.0.1), and the URI it is bound
// to ("tcp://[::1]:40123"); `scheme` names it. Throws Error(invalid_argument) for a bad
// address, Error(io_error) when it cannot be bound.
struct BoundTcp {
  boost::asio::ip::tcp::acceptor acceptor;
  std::string endpoint;
};
BoundTcp bind_tcp(boost::asio::io_context& io, std::string_view scheme, const std::string& host,
                  std::uint16_t port);

}  // namespace gonio::daemon::net
