// JSON-RPC 2.0 (https://www.jsonrpc.org/specification) — message handling, independent of
// the transport.
//
// The Dispatcher takes one message (a request, a notification or a batch) as text and
// produces the response text: batches answer with an array in request order, notifications
// (no "id") never answer, an all-notification batch answers with nothing, an empty batch is
// one -32600. Standard codes: -32700 parse error, -32600 invalid request, -32601 method not
// found, -32602 invalid params, -32603 internal error. Server errors (-32000…-32099) map
// from gonio::Errc with fixed meanings (code_for(); the table is in proto/openrpc.json);
// error.data is {"errc": "<id>", "field": "<field>"} so that clients can point at the
// offending input.
//
// Methods declare the least role that may call them and whether they block (instrument,
// twin, file work): blocking ones run on the worker executor so that the network threads
// never wait on a device, and control methods (pause, cancel, stop, reset) on an executor
// of their own, so that a queue of slow viewer work cannot delay them.
//
// Memory is bounded by the limits, not by the client: a message is scanned before it is
// parsed (nesting depth, batch elements, number of JSON values), a batch runs at most
// `batch_window` elements at a time, and a response larger than `max_response_bytes`
// becomes an error for that call.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "gonio/daemon/rpc/auth.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon::rpc {

namespace code {
inline constexpr int parse_error = -32700;
inline constexpr int invalid_request = -32600;
inline constexpr int method_not_found = -32601;
inline constexpr int invalid_params = -32602;
inline constexpr int internal_error = -32603;
// Server errors, stable meanings (proto/openrpc.json, x-error-codes).
inline constexpr int unauthorized = -32000;      // no or unknown token: auth.login first
inline constexpr int forbidden = -32001;         // the token's role may not call this
inline constexpr int not_found = -32002;         // no such sample / scan / alert / token
inline constexpr int invalid_state = -32003;     // not allowed in the current state
inline constexpr int instrument_busy = -32004;   // the instrument is running a scan or a command
inline constexpr int instrument_fault = -32005;  // a device failed (timeout, alarm, link, ...)
inline constexpr int plan_rejected = -32006;     // a scan plan failed validation
inline constexpr int limit_violation = -32007;   // a move outside soft limits / collision zone
inline constexpr int unsupported = -32008;       // valid but not possible here
inline constexpr int io_error = -32009;          // the server could not read or write a file
inline constexpr int overloaded = -32010;        // too many requests in flight on a connection
inline constexpr int storage_unavailable = -32011;  // the store cannot write; reads go on
}  // namespace code

// The JSON-RPC code of a gonio::Error.
int code_for(Errc e) noexcept;
// {"code", "message", "data": {"errc", "field"}}
nlohmann::json error_object(int code, std::string_view message, Errc errc = Errc::internal,
                            std::string_view field = {});
nlohmann::json error_object(const Error& e);

// JSON text of `j` that never throws: text that is not UTF-8 (a peer's bytes quoted in an
// error, a device message) is written with U+FFFD. Everything sent to a peer goes through it.
std::string json_text(const nlohmann::json& j);

// One connection (or one HTTP request): who is calling and how to push notifications.
class Session {
 public:
  Session(std::string transport, std::string peer, bool persistent);
  virtual ~Session() = default;
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  std::uint64_t id() const noexcept { return id_; }
  const std::string& transport() const noexcept { return transport_; }
  const std::string& peer() const noexcept { return peer_; }
  // Whether notifications can reach this session (false for HTTP POST).
  bool persistent() const noexcept { return persistent_; }

  Principal principal() const;
  void set_principal(Principal p);

  // Queues a notification (one JSON text); false when the session is closed or its queue
  // is full (the transport then drops the connection).
  virtual bool push(std::shared_ptr<const std::string> message) = 0;

  // Whether the peer has gone (the connection is closed): what it asked for and could only
  // read is then not worth doing, since no answer can reach it.
  bool gone() const noexcept { return gone_.load(std::memory_order_relaxed); }

 protected:
  void mark_gone() noexcept { gone_.store(true, std::memory_order_relaxed); }

 private:
  static std::atomic<std::uint64_t> next_id_;
  std::atomic<bool> gone_{false};
  std::uint64_t id_;
  std::string transport_, peer_;
  bool persistent_;
  mutable std::mutex mu_;
  Principal principal_;
};

struct Call {
  std::shared_ptr<Session> session;
  Principal principal;
  std::string method;
  const nlohmann::json& params;  // always an object ({} when absent)
};

// An already serialised JSON value, spliced into the response as it is (for results built
// from stored JSON text, which need not be parsed and printed again).
struct RawJson {
  RawJson(std::string t = {}, std::shared_ptr<const std::string> s = nullptr)
      : text(std::move(t)), shared(std::move(s)) {}
  std::string text;
  // When set, the result is this shared text (served to every caller without a copy per
  // call until the response is assembled); `text` is then ignored.
  std::shared_ptr<const std::string> shared;
};
using Result = std::variant<nlohmann::json, RawJson>;
using Handler = std::function<Result(Call&)>;

struct Method {
  std::string name;
  Role role = Role::viewer;  // Role::none: callable before authentication
  bool blocking = false;
  Handler handler;
  bool control = false;  // runs on the control executor (when there is one)
};

// Runs a blocking task somewhere else (a worker pool). `client` is the id of the session
// the task is for, so that the pool can take clients in turn (FairQueue).
using Executor = std::function<void(std::uint64_t client, std::function<void()>)>;

struct DispatchLimits {
  std::size_t max_batch = 128;                 // elements of one batch
  std::size_t max_response_bytes = 8u << 20;   // one response, single or batch
  std::size_t max_values = 1u << 17;           // JSON values in one message (before parsing)
  std::size_t batch_window = 16;               // batch elements being processed at once
  // Answers of batches still being assembled, over all connections: a batch's answers wait
  // for each other, so without a bound every connection could hold a batch's worth.
  std::size_t max_building_bytes = 12u << 20;
};

class Dispatcher {
 public:
  explicit Dispatcher(Executor blocking, Executor control = nullptr, DispatchLimits limits = {});

  void add(Method m);
  bool has(std::string_view name) const;
  std::vector<std::string> names() const;

  // Handles one message. `reply` is called exactly once, possibly on another thread, with
  // the response text, or with an empty string when nothing is to be sent. Returns the
  // message's weight for the transport's in-flight count: the number of batch elements
  // dispatched (1 for a single request or a refused message).
  std::size_t handle(std::string_view text, const std::shared_ptr<Session>& session,
                     std::function<void(std::string)> reply) const;

  const DispatchLimits& limits() const noexcept { return limits_; }

  // Asked before every call made with a token's role: false when the token has been revoked
  // since the session logged in (the session then falls back to no role).
  void set_principal_check(std::function<bool(const Principal&)> check) { check_ = std::move(check); }
  // Asked before a method that would run on the calling (network) thread: true sends it to
  // the blocking executor instead (the client governor is holding client work there).
  void set_inline_gate(std::function<bool()> gate) { inline_gate_ = std::move(gate); }

  // Counters for system.info.
  std::uint64_t requests() const noexcept { return requests_.load(); }
  std::uint64_t errors() const noexcept { return errors_.load(); }
  // Reads not done because their caller had hung up before they started.
  std::uint64_t abandoned() const noexcept { return abandoned_.load(); }
  // Bytes of batch answers being assembled now; batch elements refused for want of room.
  std::size_t building_bytes() const noexcept { return building_.load(); }
  std::uint64_t building_refused() const noexcept { return building_refused_.load(); }

 private:
  struct Pending;
  // `done` gets the serialised response object, or an empty string for none. `whole`: the
  // request is the whole message (not a batch element), so its answer is held to
  // max_response_bytes here (a batch's elements are held to it together, in pump).
  void handle_one(nlohmann::json& request, const std::shared_ptr<Session>& session,
                  std::function<void(std::string)> done, bool whole) const;
  void pump(const std::shared_ptr<Pending>& p, const std::shared_ptr<Session>& session) const;
  // A whole message's answer `r` to the request with `id`, or the error that says it is
  // larger than max_response_bytes.
  std::string within_limit(std::string r, const nlohmann::json& id) const;
  // Takes `bytes` of the assembly budget (max_building_bytes); a small answer always fits,
  // so that errors and short results are never refused.
  bool admit_building(std::size_t bytes) const;

  Executor blocking_, control_;
  DispatchLimits limits_;
  std::function<bool(const Principal&)> check_;
  std::function<bool()> inline_gate_;
  std::map<std::string, Method, std::less<>> methods_;
  mutable std::atomic<std::uint64_t> requests_{0}, errors_{0}, abandoned_{0}, building_refused_{0};
  mutable std::atomic<std::size_t> building_{0};
};

// A response object for `id` with `result`.
nlohmann::json response(const nlohmann::json& id, nlohmann::json result);
// The same, serialised; a RawJson result is spliced in unchanged.
std::string response_text(const nlohmann::json& id, Result result);
// A notification text {"jsonrpc":"2.0","method":..,"params":..}.
std::string notification(std::string_view method, const nlohmann::json& params);

}  // namespace gonio::daemon::rpc
