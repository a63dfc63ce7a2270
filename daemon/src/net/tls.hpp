// What the TLS listeners (ndjson.cpp's tls://, http.cpp's https://) share: the server's
// context, which SIGHUP replaces, the handshake and the role a client certificate gives.
#pragma once

#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include <utility>  // before Asio: Boost 1.74's awaitable.hpp uses std::exchange without it

#include <boost/asio/ssl/context.hpp>

#include "gonio/daemon/config/config.hpp"
#include "gonio/daemon/rpc/auth.hpp"

namespace gonio::daemon::net {

// [server.tls] loaded into an OpenSSL context: TLS 1.2 and 1.3 only, forward-secret AEAD
// ciphers only. A connection takes the context current when it is accepted and keeps it
// (OpenSSL counts the references): reload() swaps in a new one for the handshakes that
// follow, and sessions already up go on with theirs.
class TlsServer {
 public:
  using Context = boost::asio::ssl::context;

  // Checks and loads the files; throws Error naming the key (server.tls.cert, ...).
  explicit TlsServer(Config::Tls files);

  std::shared_ptr<Context> current() const {
    std::lock_guard lock(mu_);
    return ctx_;
  }
  // Re-reads the files; throws Error naming the key, and the context in use stays.
  void reload();

 private:
  Config::Tls files_;
  mutable std::mutex mu_;
  std::shared_ptr<Context> ctx_;
};

// The principal of a connection whose handshake is done: the token named by its client
// certificate's subject CN when the certificate was verified (against server.tls.client_ca)
// and a token has that name; nullopt otherwise (the peer logs in as on plain TCP).
std::optional<Principal> certificate_principal(SSL* ssl, const Auth& auth, std::string_view transport);

}  // namespace gonio::daemon::net
