// What an HTTP listener (http.cpp) shares with the WebSocket sessions its connections are
// upgraded to (ws_session.cpp).
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <boost/beast/core/tcp_stream.hpp>
#include <boost/beast/http/message.hpp>
#include <boost/beast/http/string_body.hpp>
#include <boost/beast/ssl/ssl_stream.hpp>

#include "gonio/daemon/net/net.hpp"
#include "net/session.hpp"

namespace gonio::daemon::net {

// What the connections of one HTTP listener share with it.
struct HttpState {
  Context ctx;
  bool tls = false;  // https://: transports "https" and "wss"
  std::atomic<std::size_t> connections{0}, accepted{0}, dropped{0}, websockets{0};
  // Connections close() asked to end that have not ended yet (a WebSocket: its closing
  // handshake); shutdown waits a moment for them.
  std::atomic<std::size_t> ending{0};
  SessionList ws;  // for ending the sessions of a revoked token
  // Who to close on shutdown; expired entries are pruned as new ones arrive.
  std::mutex mu;
  std::vector<std::pair<std::weak_ptr<void>, std::function<void()>>> closers;
  HttpState(const Context& c, bool over_tls) : ctx(c), tls(over_tls) {}
  const char* http_transport() const { return tls ? "https" : "http"; }
  const char* ws_transport() const { return tls ? "wss" : "ws"; }
  void add_closer(std::weak_ptr<void> owner, std::function<void()> f) {
    std::lock_guard lock(mu);
    std::erase_if(closers, [](const auto& c) { return c.first.expired(); });
    closers.emplace_back(std::move(owner), std::move(f));
  }
};

// A WebSocket session on `stream`, whose upgrade request `req` was accepted at /ws: the
// handshake answers it, then text frames carry one JSON-RPC message each. `who`: the
// principal the request's bearer token or the client certificate gave (else the peer must
// log in).
using UpgradeRequest = boost::beast::http::request<boost::beast::http::string_body>;
void start_websocket(boost::beast::tcp_stream stream, std::string peer, std::shared_ptr<HttpState> st,
                     std::optional<Principal> who, UpgradeRequest req);
void start_websocket(boost::beast::ssl_stream<boost::beast::tcp_stream> stream, std::string peer,
                     std::shared_ptr<HttpState> st, std::optional<Principal> who, UpgradeRequest req);

}  // namespace gonio::daemon::net
