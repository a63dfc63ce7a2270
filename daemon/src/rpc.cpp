// JSON-RPC 2.0 message handling (see rpc.hpp).
#include "gonio/daemon/rpc.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace gonio::daemon::rpc {

// A reply must always serialise: text that is not UTF-8 (a parse error quoting the bytes it
// choked on, a device message) is written with U+FFFD rather than throwing mid-reply.
constexpr auto kInvalidUtf8 = nlohmann::json::error_handler_t::replace;

using nlohmann::json;

namespace {

constexpr std::size_t kMaxDepth = 64;

// Nesting depth of a JSON text (brackets outside strings), so that a hostile message cannot
// drive a recursive walk deep; stops counting past `limit`.
std::size_t nesting_depth(std::string_view text, std::size_t limit) {
  std::size_t depth = 0, max_depth = 0;
  bool in_string = false, escape = false;
  for (char c : text) {
    if (in_string) {
      if (escape) escape = false;
      else if (c == '\\') escape = true;
      else if (c == '"') in_string = false;
      continue;
    }
    if (c == '"') in_string = true;
    else if (c == '[' || c == '{') {
      max_depth = std::max(max_depth, ++depth);
      if (max_depth > limit) return max_depth;
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return max_depth;
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
  // Spliced rather than built as one more JSON object around the result.
  std::string body = std::holds_alternative<json>(result) ? std::get<json>(result).dump(-1, ' ', false, kInvalidUtf8)
                                                           : std::move(std::get<RawJson>(result).text);
  std::string out;
  out.reserve(body.size() + 48);
  out += R"({"jsonrpc":"2.0","result":)";
  out += body;
  out += R"(,"id":)";
  out += id.dump(-1, ' ', false, kInvalidUtf8);
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

struct Dispatcher::Pending {
  std::mutex mu;
  std::vector<std::optional<std::string>> slots;
  std::size_t remaining = 0;
  std::function<void(std::string)> reply;
};

Dispatcher::Dispatcher(Executor blocking) : blocking_(std::move(blocking)) {}

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

void Dispatcher::handle(std::string_view text, const std::shared_ptr<Session>& session,
                        std::function<void(std::string)> reply) const {
  json message;
  if (nesting_depth(text, kMaxDepth) > kMaxDepth) {
    ++errors_;
    reply(error_response(nullptr, error_object(code::invalid_request,
                                               fmt::format("message nests deeper than {} levels",
                                                           kMaxDepth),
                                               Errc::invalid_argument))
              .dump(-1, ' ', false, kInvalidUtf8));
    return;
  }
  try {
    message = json::parse(text);
  } catch (const json::exception& e) {  // parse_error, and out_of_range for a number like 1E400
    ++errors_;
    reply(error_response(nullptr, error_object(code::parse_error,
                                               fmt::format("parse error: {}", e.what()),
                                               Errc::parse_error))
              .dump(-1, ' ', false, kInvalidUtf8));
    return;
  }
  if (message.is_array()) {
    if (message.empty()) {
      ++errors_;
      reply(error_response(nullptr, error_object(code::invalid_request, "empty batch",
                                                 Errc::invalid_argument))
                .dump(-1, ' ', false, kInvalidUtf8));
      return;
    }
    auto pending = std::make_shared<Pending>();
    pending->slots.resize(message.size());
    pending->remaining = message.size();
    pending->reply = std::move(reply);
    for (std::size_t i = 0; i < message.size(); ++i) {
      handle_one(message[i], session, [pending, i](std::optional<std::string> r) {
        std::function<void(std::string)> finish;
        {
          std::lock_guard lock(pending->mu);
          pending->slots[i] = std::move(r);
          if (--pending->remaining == 0) finish = std::move(pending->reply);
        }
        if (!finish) return;
        std::string out;
        for (auto& s : pending->slots)
          if (s) out += (out.empty() ? "[" : ",") + *s;
        finish(out.empty() ? std::string() : out + "]");
      });
    }
    return;
  }
  handle_one(message, session, [reply = std::move(reply)](std::optional<std::string> r) {
    reply(r ? std::move(*r) : std::string());
  });
}

void Dispatcher::handle_one(json& req, const std::shared_ptr<Session>& session,
                            std::function<void(std::optional<std::string>)> done) const {
  ++requests_;
  const auto fail = [&](const json& id, json error) {
    ++errors_;
    done(error_response(id, std::move(error)).dump(-1, ' ', false, kInvalidUtf8));
  };
  if (!req.is_object()) {
    fail(nullptr, error_object(code::invalid_request, "a request must be a JSON object",
                               Errc::invalid_argument));
    return;
  }
  // The id, when usable, is echoed even in errors about the rest of the request.
  const auto id_it = req.find("id");
  const bool is_notification = id_it == req.end();
  json id = nullptr;
  if (!is_notification) {
    if (id_it->is_string() || id_it->is_number() || id_it->is_null()) id = *id_it;
    else {
      fail(nullptr, error_object(code::invalid_request, "id must be a string, a number or null",
                                 Errc::invalid_argument, "id"));
      return;
    }
  }
  const auto invalid = [&](std::string_view msg, std::string_view field) {
    // An invalid request gets an answer even without an id (spec §5: id null).
    fail(id, error_object(code::invalid_request, msg, Errc::invalid_argument, field));
  };
  for (const auto& [key, value] : req.items()) {
    (void)value;
    if (key != "jsonrpc" && key != "method" && key != "params" && key != "id") {
      invalid(fmt::format("unknown member '{}' (allowed: jsonrpc, method, params, id)", key), key);
      return;
    }
  }
  const auto v = req.find("jsonrpc");
  if (v == req.end() || !v->is_string() || v->get<std::string>() != "2.0") {
    invalid("jsonrpc must be exactly \"2.0\"", "jsonrpc");
    return;
  }
  const auto m = req.find("method");
  if (m == req.end() || !m->is_string()) {
    invalid("method must be a string", "method");
    return;
  }
  const std::string name = m->get<std::string>();
  json params = json::object();
  if (const auto p = req.find("params"); p != req.end()) {
    if (p->is_object()) params = std::move(*p);
    else if (p->is_array() && p->empty()) params = json::object();
    else if (p->is_array()) {
      const auto reply = [&] {
        fail(id, error_object(code::invalid_params,
                              "params: this server takes parameters by name (an object)",
                              Errc::invalid_argument, "params"));
      };
      if (is_notification) {
        ++errors_;
        done(std::nullopt);
      } else {
        reply();
      }
      return;
    } else {
      invalid("params must be an object or an array", "params");
      return;
    }
  }
  // From here on, notifications get no answer whatever happens.
  auto finish = [this, is_notification, id, done = std::move(done)](std::optional<Result> result,
                                                       std::optional<json> error) {
    if (error) ++errors_;
    if (is_notification) {
      done(std::nullopt);
      return;
    }
    done(error ? error_response(id, std::move(*error)).dump(-1, ' ', false, kInvalidUtf8) : response_text(id, std::move(*result)));
  };
  const auto it = methods_.find(name);
  if (it == methods_.end()) {
    finish(std::nullopt, error_object(code::method_not_found,
                                      fmt::format("method '{}' does not exist (rpc.discover lists "
                                                  "every method)",
                                                  name),
                                      Errc::not_found, "method"));
    return;
  }
  const Method& method = it->second;
  Principal who = session->principal();
  if (who.role < method.role) {
    if (who.role == Role::none)
      finish(std::nullopt,
             error_object(code::unauthorized,
                          fmt::format("{} needs authentication: send a bearer token (HTTP "
                                      "Authorization header, or auth.login with {{\"token\": "
                                      "...}})",
                                      name),
                          Errc::unauthorized));
    else
      finish(std::nullopt, error_object(Error::forbidden(name, to_text(method.role), who.name,
                                                         to_text(who.role))));
    return;
  }
  auto run = [&method, session, who = std::move(who), name, params = std::move(params),
              finish = std::move(finish)]() mutable {
    Call call{session, std::move(who), name, params};
    try {
      Result result = method.handler(call);
      finish(std::move(result), std::nullopt);
    } catch (const Error& e) {
      if (e.code() == Errc::internal) spdlog::error("rpc {}: {}", name, e.what());
      finish(std::nullopt, error_object(e));
    } catch (const json::exception& e) {
      finish(std::nullopt, error_object(code::invalid_params, fmt::format("params: {}", e.what()),
                                        Errc::invalid_argument, "params"));
    } catch (const std::exception& e) {
      spdlog::error("rpc {}: internal error: {}", name, e.what());
      finish(std::nullopt, error_object(code::internal_error,
                                        fmt::format("internal error: {}", e.what())));
    }
  };
  if (method.blocking && blocking_) blocking_(std::move(run));
  else run();
}

}  // namespace gonio::daemon::rpc
