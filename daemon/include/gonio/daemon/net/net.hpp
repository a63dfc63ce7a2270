// Network transports of goniod. Boost.Asio and Boost.Beast stay inside the .cpp files of
// this family (one per listener kind), so that the rest of the daemon compiles without them.
//
//   unix:PATH          NDJSON, one JSON-RPC message per line; the socket file is mode 0660
//                      and a peer that can open it gets the role of its uid and groups
//                      ([auth.unix]; none: auth.login first); the audit log names it
//                      "unix:uid=N".
//   tcp://HOST:PORT    NDJSON; nothing but rpc.discover and auth.login is answered before
//                      auth.login with a valid token.
//   http://HOST:PORT   POST /rpc (one message per request, Authorization: Bearer TOKEN) and
//                      GET /ws (WebSocket, text frames, one message per frame; the bearer
//                      header at the upgrade or auth.login as the first call); GET and HEAD
//                      of anything else: the dashboard's files (web_root.hpp).
//   tls://HOST:PORT    NDJSON over TLS, and
//   https://HOST:PORT  HTTP and WebSocket (wss://) over TLS: as tcp:// and http:// once the
//                      handshake is done ([server.tls], src/net/tls.hpp). The handshake
//                      must finish within read_timeout; until then a connection has no
//                      session, no role and no buffers but OpenSSL's. A verified client
//                      certificate whose CN names a token logs the peer in as that token.
//
// Every connection: a size limit per message (the connection is told -32600 and closed),
// a read timeout for a started message (stalled peers are dropped), an optional idle
// timeout, a login deadline for peers without a role, at most `max_in_flight` requests
// (batch elements) being processed (reading pauses), and an outgoing queue bounded in
// messages and bytes, per connection and over all of them, with a deadline on every write:
// a peer that does not read is dropped rather than buffered (counted as a slow reader).
// The queue, the write and login deadlines and the slow-reader rule are written once for
// every transport (src/net/session.hpp: StreamSession, under NDJSON and WebSocket sessions).
// Reading also pauses while a connection has more than kReadPauseBytes waiting to go out,
// so a client that pipelines requests without reading the answers stops being served
// before it costs memory.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio/any_io_executor.hpp>
#include <nlohmann/json.hpp>

#include "gonio/daemon/config/config.hpp"
#include "gonio/daemon/instrument/alerts.hpp"
#include "gonio/daemon/net/web_root.hpp"
#include "gonio/daemon/rpc/auth.hpp"
#include "gonio/daemon/rpc/hub.hpp"
#include "gonio/daemon/rpc/rpc.hpp"
#include "gonio/proto/json_writer.hpp"

namespace boost::asio {
class io_context;
}

namespace gonio::daemon::net {

inline constexpr std::size_t kReadPauseBytes = 256 << 10;

struct Limits {
  std::size_t max_message_bytes = 1 << 20;
  std::chrono::milliseconds read_timeout{10000};
  std::chrono::milliseconds idle_timeout{0};
  std::chrono::milliseconds write_timeout{10000};
  std::chrono::milliseconds login_timeout{10000};
  std::size_t max_queue = 1024;
  std::size_t max_queue_bytes = 16u << 20;
  std::size_t max_buffered_bytes = 64u << 20;
  std::size_t max_connections = 512;
  std::size_t max_in_flight = 16;
  std::vector<std::string> allowed_origins;
  // Unix-socket peers' roles (Config::unix_roles with the defaults filled in).
  std::vector<std::uint32_t> admin_uids, admin_gids, technician_uids, technician_gids,
      viewer_uids, viewer_gids;

  static Limits from(const Config& c);
};

// Counters and the shared outgoing byte budget of every listener (system.info "net").
struct NetStats {
  std::atomic<std::size_t> buffered_bytes{0};        // unparsed input and queued output, all connections
  std::atomic<std::uint64_t> slow_readers{0};        // dropped: queue full or write deadline
  std::atomic<std::uint64_t> login_timeouts{0};      // dropped: no login within the deadline
  std::atomic<std::uint64_t> refused_origin{0};      // WebSocket upgrades / POSTs from a foreign origin
  std::atomic<std::uint64_t> refused_content_type{0};  // POST /rpc without application/json
  std::atomic<std::uint64_t> accept_backoffs{0};     // accept() out of file descriptors
  std::atomic<std::uint64_t> overload_dropped{0};    // dropped mid-message: the shared budget was full
  std::atomic<std::uint64_t> revoked_sessions{0};    // ended because their token was revoked
  void write(JsonWriter& w) const;  // the members of system.info's "net"
};

class TlsServer;  // src/net/tls.hpp

struct Context {
  const rpc::Dispatcher& dispatcher;
  Hub& hub;
  const Auth& auth;
  Limits limits;
  NetStats& stats;
  std::shared_ptr<const WebRoot> web;  // the dashboard, served by GET on HTTP listeners
  // The executor each new connection runs on (goniod: one of its io threads' own
  // io_contexts, in turn). Unset: a strand of the listener's io_context.
  std::function<boost::asio::any_io_executor()> connection_executor;
  // The certificate of the tls:// and https:// listeners; null without [server.tls].
  std::shared_ptr<TlsServer> tls;
};

class Listener {
 public:
  virtual ~Listener() = default;
  virtual std::string endpoint() const = 0;  // the bound URI (real port when 0 was asked)
  virtual void close() = 0;                  // stops accepting and closes every connection
  // Whether connections that close() asked to end have not ended yet (a WebSocket ends with
  // its closing handshake: the peer answers the server's Close frame). Shutdown waits a
  // moment for them before the io threads stop.
  virtual bool closing() const = 0;
  // The members of its system.info "transport" entry: endpoint, connections, accepted,
  // dropped (and websockets on HTTP).
  virtual void write_stats(JsonWriter& w) const = 0;
  // Ends every live session logged in with the token `name` (it was revoked).
  virtual void end_sessions_of(const std::string& name) = 0;
};

// Throw Error(io_error) when the address cannot be bound.
std::shared_ptr<Listener> listen_unix(boost::asio::io_context& io, const std::string& path,
                                      const Context& ctx);
std::shared_ptr<Listener> listen_tcp(boost::asio::io_context& io, const std::string& host,
                                     std::uint16_t port, const Context& ctx);
std::shared_ptr<Listener> listen_http(boost::asio::io_context& io, const std::string& host,
                                      std::uint16_t port, const Context& ctx);

// Over TLS (ctx.tls must be set).
std::shared_ptr<Listener> listen_tls(boost::asio::io_context& io, const std::string& host,
                                     std::uint16_t port, const Context& ctx);
std::shared_ptr<Listener> listen_https(boost::asio::io_context& io, const std::string& host,
                                       std::uint16_t port, const Context& ctx);

// [server.tls]: the files exist and can be read, the key is its owner's alone and is the
// certificate's, the certificate is valid now. Throws Error naming the key
// (server.tls.cert, .key, .client_ca); nothing when [server.tls] is not set.
void check_tls_files(const Config::Tls& tls);
// The context of [server.tls] (checked as above), null when it is not set.
std::shared_ptr<TlsServer> make_tls_server(const Config& config);
// SIGHUP: the files read again for new handshakes; throws Error as above, and the
// certificate in use stays.
void reload_tls(TlsServer& tls);

// The alert webhook: POSTs each payload as JSON to `url` with retries and back-off.
std::shared_ptr<AlertSink> make_webhook(boost::asio::io_context& io, const Config& config);

}  // namespace gonio::daemon::net
