// goniod configuration: the URIs and ids it holds, TOML in and out, the checks across
// keys. The keys themselves are described in config_keys.cpp.
#include "gonio/daemon/config/config.hpp"

#include <arpa/inet.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio::daemon {
namespace {

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
  } else if (text.starts_with("tls://")) {
    u.kind = Kind::tls;
    host_port(text.substr(6), "tls://");
  } else if (text.starts_with("https://")) {
    u.kind = Kind::https;
    host_port(text.substr(8), "https://");
  } else {
    throw Error::invalid(f, fmt::format("'{}' is not unix:PATH, tcp://HOST:PORT, http://HOST:PORT, "
                                        "tls://HOST:PORT or https://HOST:PORT",
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
    case Kind::tls: return "tls://" + hp;
    case Kind::https: return "https://" + hp;
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

Config Config::mock_defaults() {
  Config c;
  c.motion = json{{"driver", "mock"}, {"sample", kDemoSampleBsdf}};
  c.photometer = json{{"driver", "mock"}};
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
  for (std::size_t i = 0; i < listen.size(); ++i)
    if (listen[i].tls() && (tls.cert.empty() || tls.key.empty()))
      throw Error::invalid(fmt::format("server.listen[{}]", i),
                           fmt::format("{} needs a certificate and its key: set server.tls.cert and "
                                       "server.tls.key",
                                       listen[i].to_string()));
  if (tls.cert.empty() != tls.key.empty())
    throw Error::invalid(tls.cert.empty() ? "server.tls.cert" : "server.tls.key",
                         "server.tls.cert and server.tls.key go together");
  if (!tls.client_ca.empty() && tls.cert.empty())
    throw Error::invalid("server.tls.client_ca", "needs server.tls.cert and server.tls.key");
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
