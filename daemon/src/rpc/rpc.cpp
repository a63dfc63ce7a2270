// JSON-RPC 2.0 message handling (see rpc.hpp).
#include "gonio/daemon/rpc/rpc.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace gonio::daemon::rpc {

// A reply must always serialise: text that is not UTF-8 (a parse error quoting the bytes it
// choked on, a device message) is written with U+FFFD rather than throwing mid-reply.
constexpr auto kInvalidUtf8 = nlohmann::json::error_handler_t::replace;

using nlohmann::json;

std::string json_text(const nlohmann::json& j) { return j.dump(-1, ' ', false, kInvalidUtf8); }

namespace {

constexpr std::size_t kMaxDepth = 64;

// What a message holds, read from its text before it is parsed, so that a hostile message is
// refused before it costs memory: nesting depth (stops counting past the limit), whether it
// is a batch and its elements, and a count of JSON values (brackets, strings and commas: an
// upper bound of the parsed tree's nodes give or take one per container).
struct Shape {
  std::size_t max_depth = 0;
  bool batch = false;
  std::size_t elements = 0;  // top-level elements of a batch
  std::size_t values = 0;
};

Shape shape_of(std::string_view text, std::size_t depth_limit) {
  Shape s;
  std::size_t depth = 0;
  bool in_string = false, escape = false, seen_top = false, batch_has_value = false;
  for (char c : text) {
    if (in_string) {
      if (escape) escape = false;
      else if (c == '\\') escape = true;
      else if (c == '"') in_string = false;
      continue;
    }
    if (c == ' ' || c == '\t' || c == '\n' || c == '\r') continue;
    if (!seen_top) {
      seen_top = true;
      s.batch = c == '[';
    }
    if (s.batch && depth == 1 && c != ']' && c != ',') batch_has_value = true;
    if (c == '"') {
      in_string = true;
      ++s.values;
    } else if (c == '[' || c == '{') {
      ++s.values;
      s.max_depth = std::max(s.max_depth, ++depth);
      if (s.max_depth > depth_limit) return s;
    } else if (c == ']' || c == '}') {
      if (depth > 0) --depth;
    } else if (c == ',') {
      ++s.values;
      if (s.batch && depth == 1) ++s.elements;
    }
  }
  if (s.batch && batch_has_value) ++s.elements;  // elements = commas + 1 when not empty
  return s;
}

json error_response(const json& id, json error) {
  return json{{"jsonrpc", "2.0"}, {"error", std::move(error)}, {"id", id}};
}

}  // namespace

int code_for(Errc e) noexcept {
  switch (e) {
    case Errc::invalid_argument:
    case Errc::out_of_range:
    case Errc::parse_error: return code::invalid_params;
    case Errc::not_found: return code::not_found;
    case Errc::unsupported: return code::unsupported;
    case Errc::io_error: return code::io_error;
    case Errc::timeout:
    case Errc::disconnected:
    case Errc::device_alarm:
    case Errc::protocol_error:
    case Errc::saturated: return code::instrument_fault;
    case Errc::limit_violation: return code::limit_violation;
    case Errc::busy: return code::instrument_busy;
    case Errc::invalid_state: return code::invalid_state;
    case Errc::unauthorized: return code::unauthorized;
    case Errc::forbidden: return code::forbidden;
    case Errc::plan_rejected: return code::plan_rejected;
    case Errc::storage_unavailable: return code::storage_unavailable;
    case Errc::internal: return code::internal_error;
  }
  return code::internal_error;
}

json error_object(int c, std::string_view message, Errc errc, std::string_view field) {
  json data{{"errc", errc_id(errc)}};
  if (!field.empty()) data["field"] = field;
  return json{{"code", c}, {"message", message}, {"data", std::move(data)}};
}

json error_object(const Error& e) { return error_object(code_for(e.code()), e.what(), e.code(), e.field()); }

json response(const json& id, json result) {
  return json{{"jsonrpc", "2.0"}, {"result", std::move(result)}, {"id", id}};
}

std::string response_text(const json& id, Result result) {
  static constexpr std::string_view kHead = R"({"jsonrpc":"2.0","result":)", kIdKey = R"(,"id":)";
  const auto id_text = id.dump(-1, ' ', false, kInvalidUtf8);
  // A result the method wrote as text with room to spare is wrapped where it lies (saves an
  // allocation and a copy of the answer per call; growing a full string instead would double
  // a large answer's memory); the others are spliced rather than built as one more JSON
  // object around the result.
  const auto envelope = kHead.size() + kIdKey.size() + id_text.size() + 1;
  if (auto* raw = std::get_if<RawJson>(&result); raw && !raw->shared && raw->text.capacity() >= raw->text.size() + envelope) {
    auto out = std::move(raw->text);
    out.insert(0, kHead);
    out += kIdKey;
    out += id_text;
    out += '}';
    return out;
  }
  std::string body;
  const std::string* text = &body;
  if (std::holds_alternative<json>(result)) body = std::get<json>(result).dump(-1, ' ', false, kInvalidUtf8);
  else if (const auto& raw = std::get<RawJson>(result); raw.shared) text = raw.shared.get();
  else text = &raw.text;  // written as text without room for the envelope
  std::string out;
  out.reserve(text->size() + envelope);
  out += kHead;
  out += *text;
  body = std::string();
  out += kIdKey;
  out += id_text;
  out += '}';
  return out;
}

std::string notification(std::string_view method, const json& params) {
  return json{{"jsonrpc", "2.0"}, {"method", method}, {"params", params}}.dump(-1, ' ', false, kInvalidUtf8);
}

// ---- sessions ----------------------------------------------------------------------------

std::atomic<std::uint64_t> Session::next_id_{1};

Session::Session(std::string transport, std::string peer, bool persistent)
    : id_(next_id_++), transport_(std::move(transport)), peer_(std::move(peer)),
      persistent_(persistent) {
  principal_.transport = transport_;
  principal_.name = "anonymous";
}

Principal Session::principal() const {
  std::lock_guard lock(mu_);
  return principal_;
}

void Session::set_principal(Principal p) {
  std::lock_guard lock(mu_);
  principal_ = std::move(p);
}

// ---- dispatcher --------------------------------------------------------------------------

// A batch in progress: the parsed message lives here until every element has answered;
// elements start at most `window` at a time (the rest wait for a slot), and the answers are
// collected in request order within the response size limit.
struct Dispatcher::Pending {
  std::mutex mu;
  json message;
  std::vector<json> ids;  // each element's id (null when unusable), for errors in its place
  std::vector<std::optional<std::string>> slots;
  std::vector<char> done;  // per element: answered (a notification answers with nothing)
  std::string out;         // the answers so far, in request order: slots are moved in as
                           // soon as every earlier element has answered
  std::size_t next = 0, running = 0, remaining = 0, bytes = 2, flushed = 0;
  std::size_t held = 0;  // of the dispatcher's assembly budget, given back when the answer goes
  bool pumping = false;
  std::function<void(std::string)> reply;
};

Dispatcher::Dispatcher(Executor blocking, Executor control, DispatchLimits limits)
    : blocking_(std::move(blocking)), control_(std::move(control)), limits_(limits) {}

void Dispatcher::add(Method m) {
  const auto name = m.name;
  methods_[name] = std::move(m);
}

bool Dispatcher::has(std::string_view name) const { return methods_.find(name) != methods_.end(); }

std::vector<std::string> Dispatcher::names() const {
  std::vector<std::string> out;
  for (const auto& [name, m] : methods_) out.push_back(name);
  return out;
}

namespace {

// An answer this small is always admitted to the assembly budget (errors, short results).
constexpr std::size_t kSmallAnswer = 64u << 10;

std::string no_room_text(const json& id, std::size_t bytes, std::size_t limit) {
  return error_response(id, error_object(code::overloaded,
                                         fmt::format("goniod is assembling other batches' answers "
                                                     "(server.max_building_bytes = {}) and this "
                                                     "element's {} bytes do not fit; ask again, "
                                                     "or for less at a time",
                                                     limit, bytes),
                                         Errc::busy))
      .dump(-1, ' ', false, kInvalidUtf8);
}

std::string too_large_text(const json& id, std::size_t bytes, std::size_t limit) {
  return error_response(id, error_object(code::unsupported,
                                         fmt::format("the response would have {} bytes, more than "
                                                     "server.max_response_bytes = {}; ask for less "
                                                     "(a smaller page or batch)",
                                                     bytes, limit),
                                         Errc::unsupported))
      .dump(-1, ' ', false, kInvalidUtf8);
}

}  // namespace

std::size_t Dispatcher::handle(std::string_view text, const std::shared_ptr<Session>& session,
                               std::function<void(std::string)> reply) const {
  const auto refuse = [&](int c, std::string message, Errc errc) {
    ++errors_;
    reply(error_response(nullptr, error_object(c, message, errc)).dump(-1, ' ', false, kInvalidUtf8));
    return std::size_t{1};
  };
  const Shape shape = shape_of(text, kMaxDepth);
  if (shape.max_depth > kMaxDepth)
    return refuse(code::invalid_request, fmt::format("message nests deeper than {} levels", kMaxDepth),
                  Errc::invalid_argument);
  if (shape.batch && shape.elements > limits_.max_batch)
    return refuse(code::invalid_request,
                  fmt::format("a batch has {} elements, more than server.max_batch = {}",
                              shape.elements, limits_.max_batch),
                  Errc::out_of_range);
  if (shape.values > limits_.max_values)
    return refuse(code::invalid_request,
                  fmt::format("the message holds {} JSON values, more than the limit of {}",
                              shape.values, limits_.max_values),
                  Errc::out_of_range);
  json message;
  try {
    message = json::parse(text);
  } catch (const json::exception& e) {  // parse_error, and out_of_range for a number like 1E400
    return refuse(code::parse_error, fmt::format("parse error: {}", e.what()), Errc::parse_error);
  }
  if (message.is_array()) {
    if (message.empty()) return refuse(code::invalid_request, "empty batch", Errc::invalid_argument);
    const std::size_t n = message.size();
    auto pending = std::make_shared<Pending>();
    pending->message = std::move(message);
    pending->slots.resize(n);
    pending->done.resize(n, 0);
    pending->ids.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const auto& e = pending->message[i];
      if (const auto it = e.is_object() ? e.find("id") : e.end();
          e.is_object() && it != e.end() && (it->is_string() || it->is_number()))
        pending->ids[i] = *it;
    }
    pending->remaining = n;
    pending->reply = std::move(reply);
    pump(pending, session);
    return n;
  }
  handle_one(message, session, std::move(reply), true);
  return 1;
}

// Starts waiting elements while the window has room. Re-entrant calls (an element that
// answers at once) only mark that more may start; the outermost call loops, so a long batch
// of quick methods does not recurse.
void Dispatcher::pump(const std::shared_ptr<Pending>& p, const std::shared_ptr<Session>& session) const {
  std::unique_lock lock(p->mu);
  if (p->pumping) return;
  p->pumping = true;
  const std::size_t window = std::max<std::size_t>(1, limits_.batch_window);
  while (p->next < p->slots.size() && p->running < window) {
    const std::size_t i = p->next++;
    ++p->running;
    lock.unlock();
    handle_one(p->message[i], session, [this, p, i, session](std::string r) {
      std::function<void(std::string)> finish;
      {
        std::lock_guard l(p->mu);
        --p->running;
        if (!r.empty()) {
          // An element that would push the whole answer over the response limit, or the
          // answers being assembled over their budget, answers with an error in its place (the
          // call gets an error, not a partial reply). What is kept counts against the budget
          // until the batch's answer goes; an error is small, so it always fits.
          bool admitted = false;
          if (p->bytes + r.size() + 1 > limits_.max_response_bytes) {
            ++errors_;
            r = too_large_text(p->ids[i], p->bytes + r.size() + 1, limits_.max_response_bytes);
          } else if (admit_building(r.size() + 1)) {
            admitted = true;
          } else {
            ++errors_;
            ++building_refused_;
            r = no_room_text(p->ids[i], r.size() + 1, limits_.max_building_bytes);
          }
          if (!admitted) admit_building(r.size() + 1);
          p->held += r.size() + 1;
          p->bytes += r.size() + 1;
          p->slots[i] = std::move(r);
        }
        p->done[i] = 1;
        for (; p->flushed < p->slots.size() && p->done[p->flushed]; ++p->flushed) {
          auto& slot = p->slots[p->flushed];
          if (!slot) continue;
          // Room for the largest answer allowed, taken once: growing by doubling would copy
          // the answer and hold up to twice its bytes, which the assembly budget does not
          // see. Pages not yet written cost no memory.
          if (const auto need = p->out.size() + slot->size() + 2; need > p->out.capacity() && need > kSmallAnswer)
            p->out.reserve(limits_.max_response_bytes + 2);
          p->out += p->out.empty() ? '[' : ',';
          p->out += *slot;
          slot.reset();
        }
        if (--p->remaining == 0) finish = std::move(p->reply);
      }
      if (finish) {
        std::string out = std::move(p->out);
        if (!out.empty()) out += ']';
        p->message = json();
        finish(std::move(out));
        building_ -= p->held;
        return;
      }
      pump(p, session);
    }, false);
    lock.lock();
  }
  p->pumping = false;
}

namespace {

// A request's members once checked (JSON-RPC 2.0 §4), or the error it is refused with.
struct Envelope {
  json id = nullptr;  // echoed, when usable, even in errors about the rest of the request
  bool notification = false;
  std::string method;
  json params = json::object();
  std::optional<json> error;
  bool answer_error = true;  // false: a notification refused without an answer
};

Envelope read_envelope(json& req) {
  Envelope e;
  const auto refuse = [&](std::string_view msg, std::string_view field) {
    // An invalid request gets an answer even without an id (spec §5: id null).
    e.error = error_object(code::invalid_request, msg, Errc::invalid_argument, field);
    return std::move(e);
  };
  if (!req.is_object()) return refuse("a request must be a JSON object", {});
  const auto id_it = req.find("id");
  e.notification = id_it == req.end();
  if (!e.notification) {
    if (!(id_it->is_string() || id_it->is_number() || id_it->is_null()))
      return refuse("id must be a string, a number or null", "id");
    e.id = *id_it;
  }
  for (const auto& [key, value] : req.items()) {
    (void)value;
    if (key != "jsonrpc" && key != "method" && key != "params" && key != "id")
      return refuse(fmt::format("unknown member '{}' (allowed: jsonrpc, method, params, id)", key), key);
  }
  const auto v = req.find("jsonrpc");
  if (v == req.end() || !v->is_string() || v->get<std::string>() != "2.0")
    return refuse("jsonrpc must be exactly \"2.0\"", "jsonrpc");
  const auto m = req.find("method");
  if (m == req.end() || !m->is_string()) return refuse("method must be a string", "method");
  e.method = m->get<std::string>();
  if (const auto p = req.find("params"); p != req.end()) {
    if (p->is_object()) {
      e.params = std::move(*p);
    } else if (p->is_array() && !p->empty()) {
      e.error = error_object(code::invalid_params, "params: this server takes parameters by name (an object)",
                             Errc::invalid_argument, "params");
      e.answer_error = !e.notification;
    } else if (!p->is_array()) {
      return refuse("params must be an object or an array", "params");
    }
  }
  return e;
}

// Why `who` may not call `method`, if they may not.
std::optional<json> refusal(const Method& method, const std::string& name, const Principal& who) {
  if (who.role >= method.role) return std::nullopt;
  if (who.role == Role::none)
    return error_object(code::unauthorized,
                        fmt::format("{} needs authentication: send a bearer token (HTTP "
                                    "Authorization header, or auth.login with {{\"token\": "
                                    "...}})",
                                    name),
                        Errc::unauthorized);
  return error_object(Error::forbidden(name, to_text(method.role), who.name, to_text(who.role)));
}

// Runs the handler; every failure becomes the call's error object.
template <class Finish>
void invoke(const Method& method, Call call, Finish& finish) {
  try {
    Result result = method.handler(call);
    finish(std::move(result), std::nullopt);
  } catch (const Error& e) {
    if (e.code() == Errc::internal) spdlog::error("rpc {}: {}", call.method, e.what());
    finish(std::nullopt, error_object(e));
  } catch (const json::exception& e) {
    finish(std::nullopt, error_object(code::invalid_params, fmt::format("params: {}", e.what()),
                                      Errc::invalid_argument, "params"));
  } catch (const std::exception& e) {
    spdlog::error("rpc {}: internal error: {}", call.method, e.what());
    finish(std::nullopt, error_object(code::internal_error, fmt::format("internal error: {}", e.what())));
  }
}

}  // namespace

bool Dispatcher::admit_building(std::size_t bytes) const {
  const auto now = building_.fetch_add(bytes) + bytes;
  if (bytes <= kSmallAnswer || now <= limits_.max_building_bytes) return true;
  building_ -= bytes;
  return false;
}

std::string Dispatcher::within_limit(std::string r, const json& id) const {
  if (r.size() <= limits_.max_response_bytes) return r;
  ++errors_;
  return too_large_text(id.is_string() || id.is_number() ? id : json(nullptr), r.size(), limits_.max_response_bytes);
}

void Dispatcher::handle_one(json& req, const std::shared_ptr<Session>& session,
                            std::function<void(std::string)> done, bool whole) const {
  ++requests_;
  Envelope env = read_envelope(req);
  if (env.error) {
    ++errors_;
    if (!env.answer_error) done(std::string());
    else if (auto r = error_response(env.id, std::move(*env.error)).dump(-1, ' ', false, kInvalidUtf8); whole)
      done(within_limit(std::move(r), env.id));
    else done(std::move(r));
    return;
  }
  // From here on, notifications get no answer whatever happens.
  auto finish = [this, notification = env.notification, id = env.id, done = std::move(done), whole](
                    std::optional<Result> result, std::optional<json> error) {
    if (error) ++errors_;
    if (notification || (!result && !error)) {
      done(std::string());
      return;
    }
    auto r = error ? error_response(id, std::move(*error)).dump(-1, ' ', false, kInvalidUtf8)
                   : response_text(id, std::move(*result));
    done(whole ? within_limit(std::move(r), id) : std::move(r));
  };
  const auto it = methods_.find(env.method);
  if (it == methods_.end()) {
    finish(std::nullopt, error_object(code::method_not_found,
                                      fmt::format("method '{}' does not exist (rpc.discover lists "
                                                  "every method)",
                                                  env.method),
                                      Errc::not_found, "method"));
    return;
  }
  const Method& method = it->second;
  Principal who = session->principal();
  if (who.role != Role::none && check_ && !check_(who)) {
    // The token was revoked since this session logged in.
    Principal anon;
    anon.transport = who.transport;
    anon.name = "anonymous";
    session->set_principal(anon);
    who = anon;
  }
  if (auto refused = refusal(method, env.method, who)) {
    finish(std::nullopt, std::move(*refused));
    return;
  }
  // Call holds its params by reference: they live in the closure that runs it. A read (a
  // method a viewer may call) whose caller has hung up by the time it would start is not
  // done: nobody can receive its answer, and a flood of abandoned reads would otherwise
  // hold up the callers still connected. Commands run whatever happens to the connection.
  auto run = [this, &method, session, who = std::move(who), name = std::move(env.method),
              params = std::move(env.params), finish = std::move(finish)]() mutable {
    if (method.role <= Role::viewer && session->gone()) {
      ++abandoned_;
      finish(std::nullopt, std::nullopt);
      return;
    }
    invoke(method, Call{session, std::move(who), name, params}, finish);
  };
  if (method.control && control_) control_(session->id(), std::move(run));
  else if ((method.blocking || (inline_gate_ && inline_gate_())) && blocking_) blocking_(session->id(), std::move(run));
  else run();
}

}  // namespace gonio::daemon::rpc
