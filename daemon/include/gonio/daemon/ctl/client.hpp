// A blocking JSON-RPC client over the NDJSON transports (unix:PATH, tcp://HOST:PORT and
// tls://HOST:PORT) and HTTP POST /rpc (http://HOST:PORT, https://HOST:PORT: no
// notifications), for gonioctl and gonio-load. Plain POSIX sockets, and OpenSSL over them
// for tls:// and https://: a command-line client needs no event loop.
//
// Notifications that arrive while waiting for a response are kept, in order, for
// next_notification().
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

struct ssl_st;
struct ssl_ctx_st;

namespace gonio::daemon {

// A JSON-RPC error response.
class RpcError : public std::runtime_error {
 public:
  RpcError(int code, const std::string& message, nlohmann::json data)
      : std::runtime_error(message), code_(code), data_(std::move(data)) {}
  int code() const noexcept { return code_; }
  const nlohmann::json& data() const noexcept { return data_; }

 private:
  int code_;
  nlohmann::json data_;
};

// The connection failed or dropped, or the server did not answer in time.
class ConnectionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Client {
 public:
  // Throws ConnectionError. tls://, https://: the server's certificate must be signed by a CA of `ca`
  // (a PEM file; empty: the system's) and name the host of the URI.
  Client(const std::string& uri, std::chrono::milliseconds timeout = std::chrono::seconds(30),
         const std::string& ca = {});
  ~Client();
  Client(Client&& other) noexcept;
  Client& operator=(Client&&) = delete;
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  const std::string& uri() const noexcept { return uri_; }
  void set_timeout(std::chrono::milliseconds t) { timeout_ = t; }

  // Sends a request and returns its result; throws RpcError or ConnectionError.
  nlohmann::json call(const std::string& method, const nlohmann::json& params = nlohmann::json::object());
  // The same, for load generators: the answer is checked (its id, and whether it is an
  // error, which then throws as call() does) by one pass over its text that builds nothing,
  // and its result is not returned. A load generator on the same cores as the server then
  // measures the server rather than its own allocation of the answer's tree.
  void call_checked(const std::string& method, const nlohmann::json& params = nlohmann::json::object());

  // auth.login with a token (needed on TCP and TLS; over HTTP every request then carries it).
  nlohmann::json login(const std::string& token);

  // The next notification (buffered or read), nullopt after `timeout` without one.
  std::optional<nlohmann::json> next_notification(std::chrono::milliseconds timeout);

 private:
  void send_all(std::string_view data);
  void start_tls(const std::string& ca);
  // Some bytes into `buf` (at most `size`) once poll said the socket is readable: > 0 read,
  // 0 nothing yet (TLS records that held no data), throws when the connection ended.
  long receive(char* buf, std::size_t size);
  // Waits for the socket (unless OpenSSL holds decrypted bytes already) and appends what
  // comes to the buffer; false when `deadline` passes first.
  bool receive_more(std::chrono::steady_clock::time_point deadline);
  void close_connection() noexcept;
  std::int64_t send_request(const std::string& method, const nlohmann::json& params);
  // The answer to `id`: kept notifications and answers to something else are passed over;
  // an error throws RpcError. `full` parses the answer into `msg` (else it is only checked).
  void await(std::int64_t id, const std::string& method, bool full, nlohmann::json& msg);
  // The next line, valid until the next read; nullopt after `timeout` without one.
  std::optional<std::string_view> next_line(std::chrono::milliseconds timeout);
  // The same for http:// and https://: the next response's body.
  std::optional<std::string_view> next_body(std::chrono::milliseconds timeout);

  int fd_ = -1;
  ssl_ctx_st* tls_ctx_ = nullptr;  // tls://
  ssl_st* tls_ = nullptr;
  bool http_ = false;  // http://, https://: POST /rpc
  std::string token_;  // http://, https://: the bearer token of every request
  std::string uri_;
  std::chrono::milliseconds timeout_;
  // Received bytes; those before consumed_ are lines already returned. Kept (with its
  // capacity) across calls, as is out_: a round trip allocates nothing for its text.
  std::string buffer_;
  std::size_t consumed_ = 0;
  std::string out_;
  std::deque<nlohmann::json> notifications_;
  std::int64_t next_id_ = 1;
};

// unix:PATH / tcp:// / tls:// / http:// / https://HOST:PORT → a connected socket fd (TCP but for unix:);
// throws ConnectionError.
int connect_uri(const std::string& uri, std::chrono::milliseconds timeout);

}  // namespace gonio::daemon
