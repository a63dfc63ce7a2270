// goniod configuration from TOML (see config.hpp; keys documented in daemon/README.md).
#include "gonio/daemon/config.hpp"

#include <arpa/inet.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio::daemon {
namespace {

using json_util::ObjectReader;
using nlohmann::json;

json node_to_json(const toml::node& n) {
  if (const auto* t = n.as_table()) {
    json o = json::object();
    for (const auto& [k, v] : *t) o[std::string(k.str())] = node_to_json(v);
    return o;
  }
  if (const auto* a = n.as_array()) {
    json arr = json::array();
    for (const auto& v : *a) arr.push_back(node_to_json(v));
    return arr;
  }
  if (const auto* s = n.as_string()) return json(s->get());
  if (const auto* i = n.as_integer()) return json(i->get());
  if (const auto* d = n.as_floating_point()) return json(d->get());
  if (const auto* b = n.as_boolean()) return json(b->get());
  std::ostringstream os;  // dates and times: their TOML text
  if (const auto* dt = n.as_date_time()) os << *dt;
  else if (const auto* d = n.as_date()) os << *d;
  else if (const auto* t = n.as_time()) os << *t;
  return json(os.str());
}

// ---- JSON -> TOML text (json_to_toml). Written here rather than with toml++'s formatter,
// which prints doubles with 17 digits (0.05 as 0.050000000000000003) or with 6.

std::string toml_key(const std::string& k) {
  const bool bare = !k.empty() && k.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                                      "abcdefghijklmnopqrstuvwxyz0123456789_-") ==
                                      std::string::npos;
  if (bare) return k;
  return json(k).dump();  // a JSON string is a TOML basic string (same escapes)
}

bool is_table_array(const json& v) {
  return v.is_array() && !v.empty() &&
         std::all_of(v.begin(), v.end(), [](const json& e) { return e.is_object(); });
}

std::string toml_value(const json& v) {
  if (v.is_string()) return v.dump();
  if (v.is_boolean() || v.is_number_integer()) return v.dump();
  if (v.is_number()) {
    // Shortest text that reads back the same double; a float keeps a '.' or an exponent.
    std::string t = fmt::format("{}", v.get<double>());
    if (t.find_first_of(".eEn") == std::string::npos) t += ".0";
    return t;
  }
  if (v.is_array()) {
    std::string t = "[";
    for (const auto& e : v) t += (t.size() > 1 ? ", " : "") + toml_value(e);
    return t + "]";
  }
  if (v.is_object()) {  // inline table, for a table inside an array of scalars and tables
    std::string t = "{";
    for (const auto& [k, e] : v.items()) t += (t.size() > 1 ? ", " : " ") + toml_key(k) + " = " + toml_value(e);
    return t + " }";
  }
  throw Error::invalid("config", "TOML has no null");
}

void toml_table(std::ostream& os, const json& t, const std::string& path) {
  for (const auto& [k, v] : t.items())
    if (!v.is_object() && !is_table_array(v) && !v.is_null()) os << toml_key(k) << " = " << toml_value(v) << "\n";
  for (const auto& [k, v] : t.items()) {
    const auto sub = path.empty() ? toml_key(k) : path + "." + toml_key(k);
    if (v.is_object()) {
      os << "\n[" << sub << "]\n";
      toml_table(os, v, sub);
    } else if (is_table_array(v)) {
      for (const auto& e : v) {
        os << "\n[[" << sub << "]]\n";
        toml_table(os, e, sub);
      }
    }
  }
}

double in_seconds(milliseconds ms) { return static_cast<double>(ms.count()) / 1000.0; }

milliseconds seconds_in(ObjectReader& r, const std::string& key, milliseconds fallback,
                        double lo_s, double hi_s) {
  const double s = r.optional_in(key, static_cast<double>(fallback.count()) / 1000.0, lo_s, hi_s);
  return milliseconds(static_cast<long long>(s * 1000.0 + 0.5));
}

bool is_hex64(const std::string& s) {
  if (s.size() != 64) return false;
  for (char c : s)
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  return true;
}

json table(ObjectReader& r, const std::string& key) {
  const auto* t = r.raw(key);
  if (!t) return json::object();
  if (!t->is_object()) throw Error::invalid(r.path(key), "expected a table");
  return *t;
}

}  // namespace

Role parse_role(std::string_view text, std::string_view field) {
  // "none" names the absence of a role; it is never granted.
  if (text == to_text(Role::none))
    throw Error::invalid(std::string(field), "'none' is not a role to grant (viewer, technician, admin)");
  return parse_enum<Role>(text, field);
}

ListenUri ListenUri::parse(std::string_view text, std::string_view field) {
  const std::string f(field);
  ListenUri u;
  const auto host_port = [&](std::string_view rest, std::string_view scheme) {
    std::string_view host, port;
    if (!rest.empty() && rest.front() == '[') {  // [::1]:7700
      const auto close = rest.find(']');
      if (close == std::string_view::npos || close + 1 >= rest.size() || rest[close + 1] != ':')
        throw Error::invalid(f, fmt::format("'{}': expected {}[ADDRESS]:PORT", text, scheme));
      host = rest.substr(1, close - 1), port = rest.substr(close + 2);
    } else {
      const auto colon = rest.rfind(':');
      if (colon == std::string_view::npos)
        throw Error::invalid(f, fmt::format("'{}': expected {}HOST:PORT", text, scheme));
      host = rest.substr(0, colon), port = rest.substr(colon + 1);
    }
    if (!port.empty() && port.back() == '/') port.remove_suffix(1);
    if (host.empty()) throw Error::invalid(f, fmt::format("'{}': empty host", text));
    unsigned long p = 0;
    if (port.empty() || port.size() > 5 ||
        port.find_first_not_of("0123456789") != std::string_view::npos ||
        (p = std::stoul(std::string(port))) > 65535)
      throw Error::invalid(f, fmt::format("'{}': port must be 0..65535", text));
    u.host = std::string(host);
    u.port = static_cast<std::uint16_t>(p);
    unsigned char buf[16];
    if (u.host != "localhost" && inet_pton(AF_INET, u.host.c_str(), buf) != 1 &&
        inet_pton(AF_INET6, u.host.c_str(), buf) != 1)
      throw Error::invalid(f, fmt::format("'{}': host must be a numeric address or localhost",
                                          text));
  };
  if (text.starts_with("unix:")) {
    u.kind = Kind::unix_socket;
    u.path = std::string(text.substr(5));
    if (u.path.empty()) throw Error::invalid(f, "unix: needs a path (unix:/run/gonio/goniod.sock)");
    if (u.path.size() >= 108)
      throw Error::invalid(f, fmt::format("socket path has {} bytes, the limit is 107",
                                          u.path.size()));
  } else if (text.starts_with("tcp://")) {
    u.kind = Kind::tcp;
    host_port(text.substr(6), "tcp://");
  } else if (text.starts_with("http://")) {
    u.kind = Kind::http;
    host_port(text.substr(7), "http://");
  } else {
    throw Error::invalid(f, fmt::format("'{}' is not unix:PATH, tcp://HOST:PORT or "
                                        "http://HOST:PORT",
                                        text));
  }
  return u;
}

MqttUrl MqttUrl::parse(std::string_view text, std::string_view field) {
  const std::string f(field);
  MqttUrl u;
  std::string_view rest;
  if (text.starts_with("mqtt://")) {
    rest = text.substr(7);
  } else if (text.starts_with("mqtts://")) {
    u.tls = true;
    u.port = 8883;
    rest = text.substr(8);
  } else {
    throw Error::invalid(f, fmt::format("'{}' is not mqtt://HOST:PORT or mqtts://HOST:PORT", text));
  }
  if (!rest.empty() && rest.back() == '/') rest.remove_suffix(1);
  std::string_view host = rest, port;
  if (!rest.empty() && rest.front() == '[') {  // [::1]:1883
    const auto close = rest.find(']');
    if (close == std::string_view::npos)
      throw Error::invalid(f, fmt::format("'{}': unclosed [ in the host", text));
    host = rest.substr(1, close - 1);
    if (close + 1 < rest.size()) {
      if (rest[close + 1] != ':') throw Error::invalid(f, fmt::format("'{}': expected ]:PORT", text));
      port = rest.substr(close + 2);
    }
  } else if (const auto colon = rest.rfind(':'); colon != std::string_view::npos) {
    host = rest.substr(0, colon), port = rest.substr(colon + 1);
  }
  if (host.empty() || host.find_first_of("/@?# ") != std::string_view::npos)
    throw Error::invalid(f, fmt::format("'{}': expected a host name or address", text));
  u.host = std::string(host);
  if (port.data() != nullptr) {
    unsigned long p = 0;
    if (port.empty() || port.size() > 5 ||
        port.find_first_not_of("0123456789") != std::string_view::npos ||
        (p = std::stoul(std::string(port))) < 1 || p > 65535)
      throw Error::invalid(f, fmt::format("'{}': port must be 1..65535", text));
    u.port = static_cast<std::uint16_t>(p);
  }
  return u;
}

std::string MqttUrl::to_string() const {
  const auto hp = host.find(':') != std::string::npos ? fmt::format("[{}]:{}", host, port)
                                                       : fmt::format("{}:{}", host, port);
  return (tls ? "mqtts://" : "mqtt://") + hp;
}

void check_instrument_id(std::string_view id, std::string_view field) {
  const bool ok = !id.empty() && id.size() <= 64 &&
                  std::all_of(id.begin(), id.end(), [](char c) {
                    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                           (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
                  });
  // MQTT topic levels and archive keys: no '/', '+', '#', spaces or control characters.
  if (!ok)
    throw Error::invalid(std::string(field),
                         fmt::format("'{}' must be 1 to 64 characters of A-Z a-z 0-9 . _ -", id));
}

std::string default_instrument_id() {
  char buf[256] = {};
  if (::gethostname(buf, sizeof buf - 1) != 0 || buf[0] == '\0') return "goniod";
  std::string id(buf);
  if (id.size() > 64) id.resize(64);
  for (char& c : id)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
          c == '.' || c == '_' || c == '-'))
      c = '-';
  return id;
}

std::string ListenUri::to_string() const {
  const auto hp = host.find(':') != std::string::npos ? fmt::format("[{}]:{}", host, port)
                                                       : fmt::format("{}:{}", host, port);
  switch (kind) {
    case Kind::unix_socket: return "unix:" + path;
    case Kind::tcp: return "tcp://" + hp;
    case Kind::http: return "http://" + hp;
  }
  return {};
}

bool ListenUri::loopback() const {
  if (kind == Kind::unix_socket || host == "localhost" || host == "::1") return true;
  in_addr a{};
  if (inet_pton(AF_INET, host.c_str(), &a) == 1) return (ntohl(a.s_addr) >> 24) == 127;
  return false;
}

json toml_to_json(std::string_view text, std::string_view source) {
  try {
    return node_to_json(toml::parse(text, source));
  } catch (const toml::parse_error& e) {
    throw Error(Errc::parse_error,
                fmt::format("{}:{}:{}: {}", source, e.source().begin.line,
                            e.source().begin.column, e.description()),
                "config");
  }
}

std::string json_to_toml(const json& doc) {
  if (!doc.is_object()) throw Error::invalid("config", "a TOML document is a table");
  std::ostringstream os;
  toml_table(os, doc, "");
  auto text = os.str();
  if (!text.empty() && text.front() == '\n') text.erase(0, 1);
  return text;
}

namespace {

// The effective configuration is printed (goniod --check-config) and may be pasted into a
// ticket: secrets in a libpq connection string, keyword form (password=...) or URI form
// (postgresql://user:secret@host/db), are shown as ***.
std::string redact_conninfo(const std::string& conninfo) {
  static const std::regex keyword(R"((password\s*=\s*)('(\\.|[^'])*'|\S+))", std::regex::icase);
  static const std::regex uri(R"(^(postgres(ql)?://[^:@/]*:)[^@/]*@)", std::regex::icase);
  return std::regex_replace(std::regex_replace(conninfo, keyword, "$1***"), uri, "$1***@");
}

}  // namespace

std::string default_web_root() { return GONIO_WEB_ROOT; }

std::string web_root_beside(std::string_view exe) {
  namespace fs = std::filesystem;
  if (exe.empty()) return {};
  const auto dir = (fs::path(exe).parent_path() / ".." / "web" / "dist").lexically_normal();
  std::error_code ec;
  return fs::is_regular_file(dir / "index.html", ec) ? dir.string() : std::string();
}

std::string Config::served_web_root(std::string_view exe) const {
  if (web_root_set) return web_root;
  auto beside = web_root_beside(exe);
  return beside.empty() ? web_root : beside;
}

json Config::to_json() const {
  json listen_uris = json::array();
  for (const auto& u : listen) listen_uris.push_back(u.to_string());
  json doc;
  doc["server"] = {{"listen", listen_uris},
                   {"allow_remote", allow_remote},
                   {"io_threads", io_threads},
                   {"rpc_threads", rpc_threads},
                   {"max_message_bytes", max_message_bytes},
                   {"read_timeout_s", in_seconds(read_timeout)},
                   {"idle_timeout_s", in_seconds(idle_timeout)},
                   {"max_queue", max_queue},
                   {"max_connections", max_connections},
                   {"web_root", web_root},
                   {"log_level", log_level}};
  if (!tokens.empty()) {
    json list = json::array();
    for (const auto& t : tokens)
      list.push_back({{"name", t.name}, {"role", to_text(t.role)}, {"sha256", t.sha256}});
    doc["auth"] = {{"token", list}};
  }
  doc["store"] = {{"synchronous", synchronous_full ? "full" : "normal"}, {"min_free_mb", min_free_mb}};
  json lim = {{"incidence", {limits.incidence_min, limits.incidence_max}},
              {"receive", {limits.receive_min, limits.receive_max}},
              {"rotation", {limits.rotation_min, limits.rotation_max}},
              {"tilt", {limits.tilt_min, limits.tilt_max}}};
  if (limits.min_separation) lim["min_separation"] = *limits.min_separation;
  doc["instrument"] = {{"profile", profile},
                       {"move_timeout_s", in_seconds(move_timeout)},
                       {"home_timeout_s", in_seconds(home_timeout)},
                       {"measure_timeout_s", in_seconds(measure_timeout)},
                       {"settle_s", in_seconds(settle)},
                       {"autorange", autorange},
                       {"integration_min_ms", integration_min_ms},
                       {"integration_max_ms", integration_max_ms},
                       {"underexposed_snr", underexposed_snr},
                       {"auto_resume", auto_resume},
                       {"auto_resume_delay_s", in_seconds(auto_resume_delay)},
                       {"max_auto_resumes", max_auto_resumes},
                       {"limits", lim}};
  if (integration_ms) doc["instrument"]["integration_ms"] = *integration_ms;
  if (!motion.empty()) doc["instrument"]["motion"] = motion;
  if (!photometer.empty()) doc["instrument"]["photometer"] = photometer;
  doc["twin"] = {{"threads", twin_threads},
                 {"rel_se", twin_rel_se},
                 {"max_samples", twin_max_samples},
                 {"replicates", twin_replicates},
                 {"seed", twin_seed}};
  doc["divergence"] = {{"coverage_k", coverage_k},
                       {"z_threshold", z_threshold},
                       {"delta_e_threshold", delta_e_threshold},
                       {"delta_uv_threshold", delta_uv_threshold},
                       {"reference_drift", reference_drift},
                       {"pause_on_sustained", pause_on_sustained}};
  doc["webhook"] = {{"url", webhook_url},
                    {"retries", webhook_retries},
                    {"backoff_s", in_seconds(webhook_backoff)},
                    {"timeout_s", in_seconds(webhook_timeout)},
                    {"min_severity", webhook_min_severity}};
  doc["mqtt"] = {{"url", mqtt.url},
                 {"instrument", mqtt.instrument},
                 {"username", mqtt.username},
                 {"password", mqtt.password.empty() ? "" : "***"},
                 {"qos", mqtt.qos},
                 {"topic_prefix", mqtt.topic_prefix},
                 {"ca_file", mqtt.ca_file},
                 {"cert_file", mqtt.cert_file},
                 {"key_file", mqtt.key_file},
                 {"queue", mqtt.queue},
                 {"keepalive_s", mqtt.keepalive_s}};
  doc["archive"] = {{"postgres", redact_conninfo(archive.postgres)},
                    {"instrument", archive.instrument},
                    {"batch", archive.batch},
                    {"retry_max_s", in_seconds(archive.retry_max)},
                    {"max_backlog_age_s", in_seconds(archive.max_backlog_age)}};
  return doc;
}

Config Config::mock_defaults() {
  Config c;
  c.motion = json{{"driver", "mock"}, {"sample", kDemoSampleBsdf}};
  c.photometer = json{{"driver", "mock"}};
  return c;
}

Config Config::parse(std::string_view text, std::string_view source, const std::optional<Config>& base) {
  const json doc = toml_to_json(text, source);
  Config c = base.value_or(Config{});
  ObjectReader top(doc, "");

  if (const json server = table(top, "server"); !server.empty()) {
    ObjectReader r(server, "server");
    if (const auto* l = r.raw("listen")) {
      if (!l->is_array()) throw Error::invalid("server.listen", "expected an array of URIs");
      c.listen.clear();
      for (std::size_t i = 0; i < l->size(); ++i) {
        const auto field = fmt::format("server.listen[{}]", i);
        c.listen.push_back(ListenUri::parse(json_util::get_as<std::string>((*l)[i], field), field));
      }
    }
    c.allow_remote = r.optional<bool>("allow_remote", c.allow_remote);
    c.io_threads = static_cast<int>(r.optional_in<long long>("io_threads", c.io_threads, 1, 64));
    c.rpc_threads = static_cast<std::size_t>(r.optional_in<long long>("rpc_threads", static_cast<long long>(c.rpc_threads), 1, 64));
    c.max_message_bytes = static_cast<std::size_t>(
        r.optional_in<long long>("max_message_bytes", static_cast<long long>(c.max_message_bytes), 1024,
                   64ll << 20));
    c.read_timeout = seconds_in(r, "read_timeout_s", c.read_timeout, 0.1, 3600);
    c.idle_timeout = seconds_in(r, "idle_timeout_s", c.idle_timeout, 0, 86400);
    c.max_queue = static_cast<std::size_t>(
        r.optional_in<long long>("max_queue", static_cast<long long>(c.max_queue), 1, 1 << 20));
    c.max_connections = static_cast<std::size_t>(
        r.optional_in<long long>("max_connections", static_cast<long long>(c.max_connections), 1, 65536));
    const auto size_in = [&](const char* key, std::size_t fallback, long long lo, long long hi) {
      return static_cast<std::size_t>(r.optional_in<long long>(key, static_cast<long long>(fallback), lo, hi));
    };
    c.max_queue_bytes = size_in("max_queue_bytes", c.max_queue_bytes, 64 << 10, 1ll << 30);
    c.max_buffered_bytes = size_in("max_buffered_bytes", c.max_buffered_bytes, 1 << 20, 16ll << 30);
    c.write_timeout = seconds_in(r, "write_timeout_s", c.write_timeout, 0.1, 3600);
    c.login_timeout = seconds_in(r, "login_timeout_s", c.login_timeout, 0.1, 3600);
    c.max_in_flight = size_in("max_in_flight", c.max_in_flight, 1, 1024);
    c.max_batch = size_in("max_batch", c.max_batch, 1, 100000);
    c.max_response_bytes = size_in("max_response_bytes", c.max_response_bytes, 64 << 10, 1ll << 30);
    if (const auto* o = r.raw("allowed_origins")) {
      if (!o->is_array()) throw Error::invalid("server.allowed_origins", "expected an array of origins");
      c.allowed_origins.clear();
      for (std::size_t i = 0; i < o->size(); ++i) {
        const auto field = fmt::format("server.allowed_origins[{}]", i);
        auto origin = json_util::get_as<std::string>((*o)[i], field);
        if (!(origin.starts_with("http://") || origin.starts_with("https://")) ||
            origin.find('/', origin.find("//") + 2) != std::string::npos || origin.size() > 256)
          throw Error::invalid(field, fmt::format("'{}' is not an origin (scheme://host[:port], no "
                                                  "path)",
                                                  origin));
        c.allowed_origins.push_back(std::move(origin));
      }
    }
    c.web_root_set = c.web_root_set || r.has("web_root");
    c.web_root = r.optional<std::string>("web_root", c.web_root);
    if (!c.web_root.empty() && c.web_root.front() != '/')
      throw Error::invalid("server.web_root", fmt::format("'{}' must be an absolute path (or empty: no dashboard)", c.web_root));
    c.log_level = r.optional<std::string>("log_level", c.log_level);
    if (c.log_level != "trace" && c.log_level != "debug" && c.log_level != "info" &&
        c.log_level != "warn" && c.log_level != "error")
      throw Error::invalid("server.log_level", fmt::format("'{}' is not one of trace, debug, "
                                                           "info, warn, error",
                                                           c.log_level));
    r.finish();
  }

  if (const json auth = table(top, "auth"); !auth.empty()) {
    ObjectReader r(auth, "auth");
    if (const auto* u = r.raw("unix")) {
      ObjectReader ur(*u, "auth.unix");
      const auto ids = [&](const char* key, std::optional<std::vector<std::uint32_t>>& out) {
        const auto* v = ur.raw(key);
        if (!v) return;
        const auto field = ur.path(key);
        if (!v->is_array()) throw Error::invalid(field, "expected an array of numeric ids");
        std::vector<std::uint32_t> list;
        for (std::size_t i = 0; i < v->size(); ++i) {
          const auto f = fmt::format("{}[{}]", field, i);
          const auto id = json_util::get_as<long long>((*v)[i], f);
          if (id < 0 || id > 4294967294ll) throw Error::out_of_range(f, static_cast<double>(id), 0, 4294967294.0);
          list.push_back(static_cast<std::uint32_t>(id));
        }
        out = std::move(list);
      };
      ids("admin_uids", c.unix_roles.admin_uids);
      ids("admin_gids", c.unix_roles.admin_gids);
      ids("technician_uids", c.unix_roles.technician_uids);
      ids("technician_gids", c.unix_roles.technician_gids);
      ids("viewer_uids", c.unix_roles.viewer_uids);
      ids("viewer_gids", c.unix_roles.viewer_gids);
      ur.finish();
    }
    if (const auto* toks = r.raw("token")) {
      if (!toks->is_array()) throw Error::invalid("auth.token", "expected [[auth.token]] tables");
      c.tokens.clear();
      for (std::size_t i = 0; i < toks->size(); ++i) {
        ObjectReader t((*toks)[i], fmt::format("auth.token[{}]", i));
        TokenEntry e;
        e.name = t.required<std::string>("name");
        if (e.name.empty() || e.name.size() > 64)
          throw Error::invalid(t.path("name"), "must have 1 to 64 characters");
        e.role = parse_role(t.required<std::string>("role"), t.path("role"));
        e.sha256 = t.required<std::string>("sha256");
        if (!is_hex64(e.sha256))
          throw Error::invalid(t.path("sha256"), "must be 64 lower-case hex digits (the SHA-256 "
                                                 "of the token; `gonioctl token-hash`)");
        t.finish();
        c.tokens.push_back(std::move(e));
      }
    }
    r.finish();
  }

  if (const json store = table(top, "store"); !store.empty()) {
    ObjectReader r(store, "store");
    const auto sync = r.optional<std::string>("synchronous", c.synchronous_full ? "full" : "normal");
    if (sync != "full" && sync != "normal")
      throw Error::invalid("store.synchronous", fmt::format("'{}' is not full or normal", sync));
    c.synchronous_full = sync == "full";
    c.min_free_mb = r.optional_in<double>("min_free_mb", c.min_free_mb, 0, 1e7, " MiB");
    r.finish();
  }

  if (const json inst = table(top, "instrument"); !inst.empty()) {
    ObjectReader r(inst, "instrument");
    c.profile = r.optional<std::string>("profile", c.profile);
    if (const auto* m = r.raw("motion")) {
      if (!m->is_object() || !m->contains("driver"))
        throw Error::invalid("instrument.motion", "expected a table with a 'driver' key");
      c.motion = *m;
    }
    if (const auto* p = r.raw("photometer")) {
      if (!p->is_object() || !p->contains("driver"))
        throw Error::invalid("instrument.photometer", "expected a table with a 'driver' key");
      c.photometer = *p;
    }
    c.move_timeout = seconds_in(r, "move_timeout_s", c.move_timeout, 0.1, 3600);
    c.home_timeout = seconds_in(r, "home_timeout_s", c.home_timeout, 0.1, 3600);
    c.measure_timeout = seconds_in(r, "measure_timeout_s", c.measure_timeout, 0.1, 3600);
    c.settle = seconds_in(r, "settle_s", c.settle, 0, 60);
    c.autorange = r.optional<bool>("autorange", c.autorange);
    if (r.has("integration_ms"))
      c.integration_ms = r.optional_in<double>("integration_ms", 100, 0.001, 3600000, " ms");
    c.integration_min_ms = r.optional_in<double>("integration_min_ms", c.integration_min_ms, 0.001, 3600000, " ms");
    c.integration_max_ms = r.optional_in<double>("integration_max_ms", c.integration_max_ms, 0.001, 3600000, " ms");
    if (c.integration_max_ms < c.integration_min_ms)
      throw Error::invalid("instrument.integration_max_ms", "must be at least integration_min_ms");
    if (c.integration_ms && (*c.integration_ms < c.integration_min_ms || *c.integration_ms > c.integration_max_ms))
      throw Error::out_of_range("instrument.integration_ms", *c.integration_ms, c.integration_min_ms,
                                c.integration_max_ms, " ms");
    c.underexposed_snr = r.optional_in<double>("underexposed_snr", c.underexposed_snr, 0, 1e6);
    c.auto_resume = r.optional<bool>("auto_resume", c.auto_resume);
    c.auto_resume_delay = seconds_in(r, "auto_resume_delay_s", c.auto_resume_delay, 0, 86400);
    c.max_auto_resumes = static_cast<int>(r.optional_in<long long>("max_auto_resumes", c.max_auto_resumes, 0, 1000));
    c.reconnect_initial = seconds_in(r, "reconnect_initial_s", c.reconnect_initial, 0.01, 3600);
    c.reconnect_max = seconds_in(r, "reconnect_max_s", c.reconnect_max, 0.01, 86400);
    if (c.reconnect_max < c.reconnect_initial)
      throw Error::invalid("instrument.reconnect_max_s", "must be at least reconnect_initial_s");
    if (const auto* lim = r.raw("limits")) {
      ObjectReader l(*lim, "instrument.limits");
      const auto pair = [&](const std::string& key, double& lo, double& hi, double min, double max) {
        const auto* v = l.raw(key);
        if (!v) return;
        const auto field = l.path(key);
        if (!v->is_array() || v->size() != 2)
          throw Error::invalid(field, "expected [MIN, MAX] in degrees");
        lo = json_util::get_as<double>((*v)[0], field + "[0]");
        hi = json_util::get_as<double>((*v)[1], field + "[1]");
        if (!(lo >= min && lo <= max)) throw Error::out_of_range(field + "[0]", lo, min, max, "°");
        if (!(hi >= lo && hi <= max)) throw Error::out_of_range(field + "[1]", hi, lo, max, "°");
      };
      pair("incidence", c.limits.incidence_min, c.limits.incidence_max, 0, 89.9);
      pair("receive", c.limits.receive_min, c.limits.receive_max, -180, 180);
      pair("rotation", c.limits.rotation_min, c.limits.rotation_max, -360, 360);
      pair("tilt", c.limits.tilt_min, c.limits.tilt_max, -360, 360);
      if (l.has("min_separation")) c.limits.min_separation = l.optional_in<double>("min_separation", 0, 0, 179);
      l.finish();
    }
    r.finish();
  }

  if (const json twin = table(top, "twin"); !twin.empty()) {
    ObjectReader r(twin, "twin");
    c.twin_threads = static_cast<unsigned>(r.optional_in<long long>("threads", c.twin_threads, 0, 256));
    c.twin_rel_se = r.optional_in<double>("rel_se", c.twin_rel_se, 1e-5, 0.5);
    c.twin_max_samples = static_cast<std::uint64_t>(
        r.optional_in<long long>("max_samples", static_cast<long long>(c.twin_max_samples), 1024, 1ll << 34));
    c.twin_replicates = static_cast<int>(r.optional_in<long long>("replicates", c.twin_replicates, 4, 1024));
    c.twin_seed = static_cast<std::uint64_t>(
        r.optional_in<long long>("seed", static_cast<long long>(c.twin_seed), 0, (1ll << 62)));
    c.twin_data_dir = r.optional<std::string>("data_dir", c.twin_data_dir);
    if (!c.twin_data_dir.empty() && c.twin_data_dir.front() != '/')
      throw Error::invalid("twin.data_dir", fmt::format("'{}' must be an absolute path", c.twin_data_dir));
    r.finish();
  }

  if (const json div = table(top, "divergence"); !div.empty()) {
    ObjectReader r(div, "divergence");
    c.coverage_k = r.optional_in<double>("coverage_k", c.coverage_k, 0.5, 10);
    c.z_threshold = r.optional_in<double>("z_threshold", c.z_threshold, 0.5, 100);
    c.delta_e_threshold = r.optional_in<double>("delta_e_threshold", c.delta_e_threshold, 0.1, 100);
    c.delta_uv_threshold = r.optional_in<double>("delta_uv_threshold", c.delta_uv_threshold, 1e-4, 0.1);
    // The m-of-n window gave way to the scan's verdict; a kept configuration still loads.
    for (const char* gone : {"sustained_m", "sustained_n"})
      if (r.raw(gone))
        c.warnings.push_back(fmt::format("divergence.{} is no longer used: the scan's verdict decides "
                                         "when a divergence is sustained",
                                         gone));
    c.reference_drift = r.optional_in<double>("reference_drift", c.reference_drift, 0.001, 1);
    c.pause_on_sustained = r.optional<bool>("pause_on_sustained", c.pause_on_sustained);
    c.diagnose = r.optional<bool>("diagnose", c.diagnose);
    r.finish();
  }

  if (const json hook = table(top, "webhook"); !hook.empty()) {
    ObjectReader r(hook, "webhook");
    c.webhook_url = r.optional<std::string>("url", c.webhook_url);
    c.webhook_retries = static_cast<int>(r.optional_in<long long>("retries", c.webhook_retries, 0, 100));
    c.webhook_backoff = seconds_in(r, "backoff_s", c.webhook_backoff, 0.01, 3600);
    c.webhook_timeout = seconds_in(r, "timeout_s", c.webhook_timeout, 0.1, 600);
    c.webhook_min_severity = r.optional<std::string>("min_severity", c.webhook_min_severity);
    if (c.webhook_min_severity != "info" && c.webhook_min_severity != "warning" &&
        c.webhook_min_severity != "critical")
      throw Error::invalid("webhook.min_severity",
                           fmt::format("'{}' is not info, warning or critical",
                                       c.webhook_min_severity));
    r.finish();
  }

  if (const json mq = table(top, "mqtt"); !mq.empty()) {
    ObjectReader r(mq, "mqtt");
    auto& m = c.mqtt;
    m.url = r.optional<std::string>("url", m.url);
    m.instrument = r.optional<std::string>("instrument", m.instrument);
    m.username = r.optional<std::string>("username", m.username);
    m.password = r.optional<std::string>("password", m.password);
    m.qos = static_cast<int>(r.optional_in<long long>("qos", m.qos, 0, 2));
    m.topic_prefix = r.optional<std::string>("topic_prefix", m.topic_prefix);
    m.ca_file = r.optional<std::string>("ca_file", m.ca_file);
    m.cert_file = r.optional<std::string>("cert_file", m.cert_file);
    m.key_file = r.optional<std::string>("key_file", m.key_file);
    m.queue = static_cast<std::size_t>(
        r.optional_in<long long>("queue", static_cast<long long>(m.queue), 16, 1000000));
    m.keepalive_s = static_cast<int>(r.optional_in<long long>("keepalive_s", m.keepalive_s, 5, 3600));
    r.finish();
  }

  if (const json ar = table(top, "archive"); !ar.empty()) {
    ObjectReader r(ar, "archive");
    auto& a = c.archive;
    a.postgres = r.optional<std::string>("postgres", a.postgres);
    a.instrument = r.optional<std::string>("instrument", a.instrument);
    a.batch = static_cast<std::size_t>(
        r.optional_in<long long>("batch", static_cast<long long>(a.batch), 1, 5000));
    a.retry_max = seconds_in(r, "retry_max_s", a.retry_max, 0.1, 3600);
    a.max_backlog_age = seconds_in(r, "max_backlog_age_s", a.max_backlog_age, 1, 7 * 86400);
    r.finish();
  }

  top.finish();
  c.validate();
  return c;
}

Config Config::load(const std::string& path, const std::optional<Config>& base) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(Errc::not_found, fmt::format("cannot open config file {}", path), "config");
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse(ss.str(), path, base);
}

void Config::validate() const {
  if (!allow_remote)
    for (std::size_t i = 0; i < listen.size(); ++i)
      if (!listen[i].loopback())
        throw Error::invalid(fmt::format("server.listen[{}]", i),
                             fmt::format("{} is not a loopback address; set "
                                         "server.allow_remote = true to listen on it",
                                         listen[i].to_string()));
  if (!webhook_url.empty()) {
    if (!webhook_url.starts_with("http://"))
      throw Error::invalid("webhook.url", fmt::format("'{}' must start with http://", webhook_url));
  }
  if (!mqtt.url.empty()) {
    const auto u = MqttUrl::parse(mqtt.url, "mqtt.url");
    if (!mqtt.instrument.empty()) check_instrument_id(mqtt.instrument, "mqtt.instrument");
    // A topic prefix of one or more levels, without wildcards or empty levels.
    const auto& p = mqtt.topic_prefix;
    if (p.empty() || p.size() > 128 || p.front() == '/' || p.back() == '/' ||
        p.find("//") != std::string::npos || p.find_first_of("+#") != std::string::npos ||
        std::any_of(p.begin(), p.end(), [](char ch) { return static_cast<unsigned char>(ch) < 0x20; }))
      throw Error::invalid("mqtt.topic_prefix",
                           fmt::format("'{}' must be 1 to 128 characters of topic levels "
                                       "('gonio', 'lab/gonio'), without + # or empty levels",
                                       p));
    if (!u.tls && (!mqtt.ca_file.empty() || !mqtt.cert_file.empty() || !mqtt.key_file.empty()))
      throw Error::invalid("mqtt.url", fmt::format("'{}': ca_file, cert_file and key_file need "
                                                   "mqtts://", mqtt.url));
    if (mqtt.cert_file.empty() != mqtt.key_file.empty())
      throw Error::invalid(mqtt.cert_file.empty() ? "mqtt.cert_file" : "mqtt.key_file",
                           "cert_file and key_file go together");
    if (mqtt.password.size() && mqtt.username.empty())
      throw Error::invalid("mqtt.username", "a password needs a username");
  } else if (!mqtt.instrument.empty() || !mqtt.username.empty() || !mqtt.ca_file.empty()) {
    throw Error::invalid("mqtt.url", "is required when [mqtt] has other keys (mqtt://HOST:PORT)");
  }
  if (!archive.postgres.empty()) {
    if (!archive.instrument.empty()) check_instrument_id(archive.instrument, "archive.instrument");
  } else if (!archive.instrument.empty()) {
    throw Error::invalid("archive.postgres",
                         "is required when [archive] names an instrument (a libpq connection "
                         "string such as 'host=db.lab dbname=gonio')");
  }
  if (!motion.empty() && !motion.contains("driver"))
    throw Error::invalid("instrument.motion.driver", "is required");
}

}  // namespace gonio::daemon
