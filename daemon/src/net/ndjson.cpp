// NDJSON transports over a Unix socket, TCP and TLS (Boost.Asio), see net.hpp.
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <atomic>
#include <filesystem>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio/buffer.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/local/stream_protocol.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core/stream_traits.hpp>
#include <boost/beast/ssl.hpp>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/net/net.hpp"
#include "net/accept.hpp"
#include "net/session.hpp"
#include "net/tls.hpp"

namespace gonio::daemon::net {

namespace asio = boost::asio;
namespace beast = boost::beast;
using boost::system::error_code;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

namespace {

// What the sessions of one listener share with it.
struct ListenerState {
  Context ctx;
  std::string kind;  // "unix", "tcp", "tls"
  std::atomic<std::size_t> connections{0}, accepted{0}, dropped{0};
  std::atomic<std::size_t> ending{0};  // sessions close() asked to end that have not yet
  SessionList sessions;
  explicit ListenerState(const Context& c, std::string k) : ctx(c), kind(std::move(k)) {}
};

// The stream a session reads and writes: the socket, or TLS over it. Beast's ssl_stream
// rather than Asio's: it gathers a write's buffers (a message and its newline) into one TLS
// record where Asio's would send one record per buffer.
template <class Protocol, bool Tls>
using StreamOf = std::conditional_t<Tls, beast::ssl_stream<typename Protocol::socket>, typename Protocol::socket>;

// An NDJSON connection: one message a line. Its queue, deadlines and slow-reader rule are
// StreamSession's; here, reading lines and writing them with their newlines.
template <class Protocol, bool Tls = false>
class NdjsonSession final : public StreamSession {
 public:
  using Stream = StreamOf<Protocol, Tls>;
  using Socket = typename Protocol::socket;

  NdjsonSession(Stream stream, std::string peer, std::shared_ptr<ListenerState> ls)
      : StreamSession(ls->kind, std::move(peer), ls->ctx, stream.get_executor(), 1),
        socket_(std::move(stream)), timer_(executor_), ls_(std::move(ls)) {}

  ~NdjsonSession() override {
    --ls_->connections;
    stats_.buffered_bytes -= input_accounted_;
  }

  void start() {
    if constexpr (Tls) {
      // The handshake has read_timeout to finish, as any started message; until then the
      // peer is in no hub, has no role and is owed nothing.
      timer_.expires_after(limits_.read_timeout);
      timer_.async_wait([self = self()](const error_code& ec) {
        if (ec || self->closed_ || self->handshaken_) return;
        self->close(fmt::format("TLS handshake did not complete within {} s",
                                std::chrono::duration<double>(self->limits_.read_timeout).count()));
      });
      socket_.async_handshake(asio::ssl::stream_base::server, [self = self()](const error_code& ec) {
        if (self->closed_) return;
        if (ec) {
          self->close("TLS handshake failed: " + ec.message());
          return;
        }
        self->handshaken_ = true;
        self->timer_.cancel();
        if (auto p = certificate_principal(self->socket_.native_handle(), self->ls_->ctx.auth, self->ls_->kind))
          self->set_principal(*p);
        self->begin();
      });
      return;
    }
    begin();
  }

  void shutdown() {
    ++ls_->ending;  // counted before it runs: shutdown waits for it
    asio::post(executor_, [self = self()] {
      self->close("the server is stopping");
      --self->ls_->ending;
    });
  }

 private:
  std::shared_ptr<NdjsonSession> self() { return std::static_pointer_cast<NdjsonSession>(shared_from_this()); }

  void begin() {
    last_activity_ = Clock::now();
    start_login_deadline();
    arm_timer();
    do_read();
  }

  // Keeps the shared budget's count of this connection's unparsed input up to date.
  void account_input() {
    const auto now = buffer_.size();
    if (now >= input_accounted_) stats_.buffered_bytes += now - input_accounted_;
    else stats_.buffered_bytes -= input_accounted_ - now;
    input_accounted_ = now;
  }

  bool may_read() const {
    return !closed_ && !close_after_write_ && in_flight_ < limits_.max_in_flight && !out_.backed_up();
  }

  void do_read() {
    if (reading_) return;
    if (!may_read()) {
      watch_for_hang_up();
      return;
    }
    // Complete lines left over from a pause are handled before anything new is read.
    if (buffer_.find('\n') != std::string::npos) {
      handle_lines();
      if (!may_read() || reading_) return;
    }
    arm_timer();
    reading_ = true;
    socket_.async_read_some(asio::buffer(chunk_), [self = self()](const error_code& ec, std::size_t n) {
      self->reading_ = false;
      self->on_read(ec, n);
    });
  }

  void on_read(const error_code& ec, std::size_t n) {
    if (closed_) return;
    if (ec) {
      close(ec == asio::error::eof ? "" : ec.message());
      return;
    }
    last_activity_ = Clock::now();
    if (buffer_.empty() && n > 0) partial_since_ = last_activity_;
    buffer_.append(chunk_.data(), n);
    account_input();
    handle_lines();
    if (closed_) return;
    // Unfinished lines count against the same budget as answers: many peers each sending
    // most of a maximal line cannot together take more than it.
    if (buffer_.size() > kReadPauseBytes && stats_.buffered_bytes.load() > limits_.max_buffered_bytes) {
      ++stats_.overload_dropped;
      close("goniod's buffers are full (server.max_buffered_bytes) and this peer sends a large message");
      return;
    }
    if (buffer_.size() > limits_.max_message_bytes && buffer_.find('\n') == std::string::npos) {
      too_large();
      return;
    }
    arm_timer();
    do_read();
  }

  // While reading is paused (requests in flight, answers backed up), a peer that hangs up
  // would go unnoticed until its answers are written, and the reads it asked for would be
  // done for nobody. So the socket is watched: readable with nothing to peek at is the end
  // of the stream (the dispatcher then skips the peer's reads not yet started). Data to
  // peek at waits for reading to resume. Over TLS a hang-up starts with a close_notify
  // record, which is data: TLS peers are noticed when reading resumes.
  void watch_for_hang_up() {
    if constexpr (!Tls) {
      if (watching_ || closed_ || close_after_write_) return;
      watching_ = true;
      socket_.async_wait(Socket::wait_read, [self = self()](const error_code& ec) {
        self->watching_ = false;
        if (ec || self->closed_ || self->reading_) return;
        char byte = 0;
        const auto n = ::recv(self->socket_.native_handle(), &byte, 1, MSG_PEEK | MSG_DONTWAIT);
        if (n == 0) {
          self->close("");
        } else if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
          self->close(std::strerror(errno));
        } else if (n < 0 && !self->may_read()) {
          self->watch_for_hang_up();
        }
      });
    }
  }

  // Dispatches the complete lines in the buffer while the connection may take more work;
  // the rest stays buffered until replies have gone out.
  void handle_lines() {
    std::size_t start = 0;
    while (may_read()) {
      const auto nl = buffer_.find('\n', start);
      if (nl == std::string::npos) break;
      std::string_view line(buffer_.data() + start, nl - start);
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      start = nl + 1;
      if (line.size() > limits_.max_message_bytes) {
        too_large();
        return;
      }
      if (line.find_first_not_of(" \t") != std::string_view::npos) {
        dispatch(line);
        if (closed_) return;
      }
    }
    if (start == 0) return;
    buffer_.erase(0, start);
    if (buffer_.empty() && buffer_.capacity() > kReadPauseBytes) buffer_.shrink_to_fit();  // a 1 MB line does not stay allocated
    else partial_since_ = Clock::now();
    account_input();
  }

  void too_large() {
    spdlog::warn("{} {}: message larger than {} bytes; closing", transport(), peer(),
                 limits_.max_message_bytes);
    buffer_.clear();
    buffer_.shrink_to_fit();
    account_input();
    enqueue(std::make_shared<const std::string>(
                json{{"jsonrpc", "2.0"},
                     {"error", rpc::error_object(rpc::code::invalid_request,
                                                 fmt::format("message exceeds the limit of {} bytes",
                                                             limits_.max_message_bytes),
                                                 Errc::out_of_range)},
                     {"id", nullptr}}
                    .dump()),
            false);
    close_after_write_ = true;
    if (!writing_) close("");
  }

  // A reply that comes back before handle() returns (every non-blocking method) is queued
  // right here on the strand; one from a worker thread is posted to it. Saves a trip through
  // the scheduler per request.
  void dispatch(std::string_view line) {
    struct Handoff {
      std::atomic<int> state{0};  // 0: in handle(), 1: replied inside it, 2: handle() returned
      std::string text;
      std::size_t weight = 1;
    };
    auto h = std::make_shared<Handoff>();
    const auto weight = ls_->ctx.dispatcher.handle(
        line, shared_from_this(), [self = self(), h](std::string response) {
          h->text = std::move(response);
          int inside = 0;
          if (h->state.compare_exchange_strong(inside, 1)) return;
          asio::post(self->executor_, [self, h, r = self->admit_reply(std::move(h->text))]() mutable {
            self->on_reply(std::move(r), h->weight);
            self->do_read();
          });
        });
    // Batch elements count one each: a batch takes as much of max_in_flight as its size.
    h->weight = weight;
    in_flight_ += weight;
    int inside = 0;
    // on_read() resumes reading after its last line.
    if (!h->state.compare_exchange_strong(inside, 2)) on_reply(std::move(h->text), weight);
  }

  // Everything queued goes out in one gathered write (replies and notifications that piled
  // up while the previous write was in flight), with a deadline.
  void write_queued() override {
    if (writing_ || out_.empty() || closed_) return;
    write_started();
    static constexpr std::size_t kMaxGather = 32;  // 64 buffers: one writev
    writing_count_ = std::min(out_.size(), kMaxGather);
    const auto done = [self = self()](const error_code& ec, std::size_t) { self->on_written(ec); };
    if (writing_count_ == 1) {
      const std::array<asio::const_buffer, 2> bufs{asio::buffer(*out_[0]), asio::buffer("\n", 1)};
      asio::async_write(socket_, bufs, done);
      return;
    }
    std::vector<asio::const_buffer> bufs;
    bufs.reserve(2 * writing_count_);
    for (std::size_t i = 0; i < writing_count_; ++i) {
      bufs.push_back(asio::buffer(*out_[i]));
      bufs.push_back(asio::buffer("\n", 1));
    }
    asio::async_write(socket_, bufs, done);
  }

  void on_written(const error_code& ec) {
    if (!write_ended(ec, writing_count_)) return;
    if (out_.empty() && close_after_write_) {
      close("");
      return;
    }
    write_queued();
    do_read();  // reading may have paused on the queue
  }

  // One timer: a started message must complete within read_timeout; an idle connection
  // lives idle_timeout (0: forever). The deadline moves with every message, so the timer is
  // not re-armed each time (a cancelled wait is a handler run through the scheduler, twice
  // per request): the deadline is a field, and the one wait outstanding checks it when it
  // fires and waits again if it has moved on. Only a deadline earlier than the wait's (a
  // line started on an idle connection) re-arms it.
  void arm_timer() {
    if (closed_) return;
    std::optional<Clock::time_point> deadline;
    if (!buffer_.empty()) deadline = partial_since_ + limits_.read_timeout;
    else if (limits_.idle_timeout.count() > 0) deadline = last_activity_ + limits_.idle_timeout;
    deadline_ = deadline.value_or(Clock::time_point::max());
    if (deadline && (!waiting_ || *deadline < wait_until_)) wait_for_deadline();
  }

  void wait_for_deadline() {
    waiting_ = true;
    wait_until_ = deadline_;
    timer_.expires_at(deadline_);
    timer_.async_wait([self = self(), generation = ++wait_generation_](const error_code& ec) {
      if (generation != self->wait_generation_) return;  // replaced by an earlier deadline
      self->waiting_ = false;
      if (ec || self->closed_ || self->deadline_ == Clock::time_point::max()) return;
      if (Clock::now() < self->deadline_) {  // moved on meanwhile
        self->wait_for_deadline();
        return;
      }
      // Complete lines waiting for replies to drain are not a stalled peer (the write
      // deadline covers one that does not read).
      if (!self->buffer_.empty() && self->buffer_.find('\n') != std::string::npos) return;
      self->close(self->buffer_.empty() ? "idle timeout" : "read timeout (message never completed)");
    });
  }

  void close(const std::string& why) override {
    if (!mark_closed(why)) return;
    if (!why.empty()) ++ls_->dropped;
    error_code ignored;
    timer_.cancel();
    // Over TLS too: the socket is closed without a close_notify, which a peer that stopped
    // reading would never take.
    beast::get_lowest_layer(socket_).shutdown(Socket::shutdown_both, ignored);
    beast::get_lowest_layer(socket_).close(ignored);
    buffer_.clear();
    buffer_.shrink_to_fit();
    account_input();
  }

  bool watching_ = false;  // a hang-up watch is outstanding (watch_for_hang_up)
  Stream socket_;
  asio::steady_timer timer_;
  std::shared_ptr<ListenerState> ls_;
  std::array<char, 16384> chunk_{};
  std::string buffer_;
  std::size_t writing_count_ = 0;  // messages at the front of out_ being written
  bool reading_ = false, close_after_write_ = false;
  bool handshaken_ = false;  // TLS
  std::size_t input_accounted_ = 0;  // bytes of buffer_ counted in stats_.buffered_bytes
  Clock::time_point partial_since_, last_activity_, deadline_;
  Clock::time_point wait_until_;    // when the outstanding wait fires
  bool waiting_ = false;            // a wait on timer_ is outstanding
  std::uint64_t wait_generation_ = 0;
};

template <class Protocol, bool Tls = false>
class NdjsonListener final : public Listener,
                             public std::enable_shared_from_this<NdjsonListener<Protocol, Tls>> {
 public:
  using Acceptor = typename Protocol::acceptor;

  NdjsonListener(asio::io_context& io, Acceptor acceptor, std::string endpoint,
                 std::shared_ptr<ListenerState> ls)
      : io_(io), acceptor_(std::move(acceptor)), backoff_(acceptor_.get_executor()),
        endpoint_(std::move(endpoint)), ls_(std::move(ls)) {}

  void accept() {
    acceptor_.async_accept(connection_executor(io_, ls_->ctx), [self = this->shared_from_this()](
                                                       const error_code& ec,
                                                       typename Protocol::socket socket) {
      if (ec) {
        if (ec == asio::error::operation_aborted || !self->acceptor_.is_open()) return;
        self->backoff_.failed(ec, self->endpoint_, self->ls_->ctx.stats.accept_backoffs,
                              [self] { self->accept(); });
        return;
      }
      self->backoff_.succeeded();
      self->on_accept(std::move(socket));
      self->accept();
    });
  }

  void end_sessions_of(const std::string& name) override { ls_->sessions.end_sessions_of(name, ls_->ctx.stats); }

  std::string endpoint() const override { return endpoint_; }

  void close() override {
    asio::post(acceptor_.get_executor(), [self = this->shared_from_this()] {
      error_code ignored;
      self->acceptor_.close(ignored);
      self->backoff_.cancel();
    });
    for (auto& s : ls_->sessions.take()) std::static_pointer_cast<NdjsonSession<Protocol, Tls>>(s)->shutdown();
  }

  bool closing() const override { return ls_->ending.load() > 0; }

  void write_stats(JsonWriter& w) const override {
    w.member("endpoint", endpoint_)
        .member("connections", ls_->connections.load())
        .member("accepted", ls_->accepted.load())
        .member("dropped", ls_->dropped.load());
  }

 private:
  void on_accept(typename Protocol::socket socket) {
    ++ls_->accepted;
    if (ls_->connections.load() >= ls_->ctx.limits.max_connections) {
      ++ls_->dropped;
      if constexpr (Tls) {  // no handshake, no words: the peer sees the connection closed
        error_code ignored;
        socket.close(ignored);
        return;
      }
      const auto msg = std::make_shared<std::string>(
          json{{"jsonrpc", "2.0"},
               {"error", rpc::error_object(rpc::code::overloaded,
                                           fmt::format("too many connections (limit {})",
                                                       ls_->ctx.limits.max_connections),
                                           Errc::busy)},
               {"id", nullptr}}
              .dump() +
          "\n");
      auto sock = std::make_shared<typename Protocol::socket>(std::move(socket));
      asio::async_write(*sock, asio::buffer(*msg), [sock, msg](const error_code&, std::size_t) {
        error_code ignored;
        sock->close(ignored);
      });
      return;
    }
    ++ls_->connections;
    std::string peer;
    Principal principal;
    principal.transport = ls_->kind;
    if constexpr (std::is_same_v<Protocol, asio::local::stream_protocol>) {
      ucred cred{};
      socklen_t len = sizeof cred;
      const bool known = getsockopt(socket.native_handle(), SOL_SOCKET, SO_PEERCRED, &cred, &len) == 0;
      if (known) peer = fmt::format("uid={} pid={}", cred.uid, cred.pid);
      // The socket's file mode lets the peer in; its uid and groups give it a role
      // ([auth.unix]): a lab member in the socket's group is a technician, not an admin.
      std::vector<gid_t> groups(64);
      socklen_t glen = static_cast<socklen_t>(groups.size() * sizeof(gid_t));
      if (getsockopt(socket.native_handle(), SOL_SOCKET, SO_PEERGROUPS, groups.data(), &glen) != 0 && errno == ERANGE) {
        groups.resize(glen / sizeof(gid_t) + 1);
        glen = static_cast<socklen_t>(groups.size() * sizeof(gid_t));
        if (getsockopt(socket.native_handle(), SOL_SOCKET, SO_PEERGROUPS, groups.data(), &glen) != 0) glen = 0;
      }
      groups.resize(glen / sizeof(gid_t));
      if (known) groups.push_back(cred.gid);
      principal.name = fmt::format("unix:uid={}", cred.uid);
      principal.role = known ? unix_role(ls_->ctx.limits, cred.uid, groups) : Role::none;
    } else {
      error_code ec;
      // Every reply is one write: Nagle would only hold back the tail of a large one.
      socket.set_option(asio::ip::tcp::no_delay(true), ec);
      const auto ep = socket.remote_endpoint(ec);
      peer = ec ? "?" : fmt::format("{}:{}", ep.address().to_string(), ep.port());
      principal.name = "anonymous";
      principal.role = Role::none;
    }
    std::shared_ptr<NdjsonSession<Protocol, Tls>> session;
    if constexpr (Tls)
      session = std::make_shared<NdjsonSession<Protocol, Tls>>(
          StreamOf<Protocol, Tls>(std::move(socket), *ls_->ctx.tls->current()), peer, ls_);
    else
      session = std::make_shared<NdjsonSession<Protocol, Tls>>(std::move(socket), peer, ls_);
    session->set_principal(principal);
    ls_->sessions.add(session);
    session->start();
  }

  asio::io_context& io_;
  Acceptor acceptor_;
  AcceptBackoff backoff_;
  std::string endpoint_;
  std::shared_ptr<ListenerState> ls_;
};

}  // namespace

std::shared_ptr<Listener> listen_unix(asio::io_context& io, const std::string& path,
                                      const Context& ctx) {
  using P = asio::local::stream_protocol;
  namespace fs = std::filesystem;
  std::error_code fec;
  if (fs::is_socket(fs::symlink_status(path, fec))) fs::remove(path, fec);  // stale, from a crash
  P::acceptor acceptor(io);
  error_code ec;
  acceptor.open(P(), ec);
  // Created 0660 from the start (no window in which others could connect).
  const mode_t old = ::umask(0117);
  if (!ec) acceptor.bind(P::endpoint(path), ec);
  ::umask(old);
  if (!ec) acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) throw Error(Errc::io_error, fmt::format("cannot listen on unix:{}: {}", path, ec.message()));
  ::chmod(path.c_str(), 0660);
  auto ls = std::make_shared<ListenerState>(ctx, "unix");
  auto l = std::make_shared<NdjsonListener<P>>(io, std::move(acceptor), "unix:" + path, ls);
  l->accept();
  return l;
}

std::shared_ptr<Listener> listen_tcp(asio::io_context& io, const std::string& host,
                                     std::uint16_t port, const Context& ctx) {
  auto [acceptor, name] = bind_tcp(io, "tcp", host, port);
  auto ls = std::make_shared<ListenerState>(ctx, "tcp");
  auto l = std::make_shared<NdjsonListener<asio::ip::tcp>>(io, std::move(acceptor), name, ls);
  l->accept();
  return l;
}

std::shared_ptr<Listener> listen_tls(asio::io_context& io, const std::string& host,
                                     std::uint16_t port, const Context& ctx) {
  if (!ctx.tls) throw Error::invalid("server.tls.cert", "a tls:// listener needs [server.tls] cert and key");
  auto [acceptor, name] = bind_tcp(io, "tls", host, port);
  auto ls = std::make_shared<ListenerState>(ctx, "tls");
  auto l = std::make_shared<NdjsonListener<asio::ip::tcp, true>>(io, std::move(acceptor), name, ls);
  l->accept();
  return l;
}

}  // namespace gonio::daemon::net
