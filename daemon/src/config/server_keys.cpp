// The [server], [server.tls], [auth] and [auth.unix] keys of goniod.toml (key_kinds.hpp).
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "config/key_kinds.hpp"
#include "gonio/daemon/config/config.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio::daemon {
namespace {

bool is_hex64(const std::string& s) {
  return s.size() == 64 && std::all_of(s.begin(), s.end(), [](char ch) {
           return (ch >= '0' && ch <= '9') || (ch >= 'a' && ch <= 'f');
         });
}

// An array of strings, each passed to `each` with its field ("server.listen[2]"); false
// when the key is not set.
template <class Each>
bool strings(ObjectReader& r, const char* key, const char* expected, Each each) {
  const auto* v = r.raw(key);
  if (!v) return false;
  if (!v->is_array()) throw Error::invalid(r.path(key), expected);
  for (std::size_t i = 0; i < v->size(); ++i) {
    const auto f = fmt::format("{}[{}]", r.path(key), i);
    each(json_util::get_as<std::string>((*v)[i], f), f);
  }
  return true;
}

ConfigKey listen_key() {
  return custom("server", "listen", "URIs", "", "extra listen URIs (see above)",
                [](ObjectReader& r, Config& c) {
                  std::vector<ListenUri> uris;
                  if (strings(r, "listen", "expected an array of URIs",
                              [&](const std::string& s, const std::string& f) {
                                uris.push_back(ListenUri::parse(s, f));
                              }))
                    c.listen = std::move(uris);
                },
                [](const Config& c) {
                  json uris = json::array();
                  for (const auto& u : c.listen) uris.push_back(u.to_string());
                  return uris;
                });
}

ConfigKey origins_key() {
  return custom("server", "allowed_origins", "origins", "",
                "browser origins (`http://host:port`) allowed besides the listener's own host; "
                "they also get CORS on `/rpc`",
                [](ObjectReader& r, Config& c) {
                  std::vector<std::string> origins;
                  if (strings(r, "allowed_origins", "expected an array of origins",
                              [&](std::string origin, const std::string& f) {
                                if (!(origin.starts_with("http://") || origin.starts_with("https://")) ||
                                    origin.find('/', origin.find("//") + 2) != std::string::npos ||
                                    origin.size() > 256)
                                  throw Error::invalid(f, fmt::format("'{}' is not an origin "
                                                                      "(scheme://host[:port], no path)",
                                                                      origin));
                                origins.push_back(std::move(origin));
                              }))
                    c.allowed_origins = std::move(origins);
                },
                [](const Config& c) { return json(c.allowed_origins); });
}

// [auth.unix] ids: unset lists take their defaults at start, so they are printed only when set.
ConfigKey ids_key(std::string_view name,
                  std::optional<std::vector<std::uint32_t>> Config::UnixRoles::*list,
                  std::string_view shown, std::string_view doc) {
  const auto get = field(&Config::unix_roles, list);
  return with_default(
      custom("auth.unix", name, "ids", "0–4294967294", doc,
             [=](ObjectReader& r, Config& c) {
               const auto key = std::string(name);
               const auto* v = r.raw(key);
               if (!v) return;
               const auto f = r.path(key);
               if (!v->is_array()) throw Error::invalid(f, "expected an array of numeric ids");
               std::vector<std::uint32_t> ids;
               for (std::size_t i = 0; i < v->size(); ++i) {
                 const auto fi = fmt::format("{}[{}]", f, i);
                 const auto id = json_util::get_as<long long>((*v)[i], fi);
                 if (id < 0 || id > 4294967294ll)
                   throw Error::out_of_range(fi, static_cast<double>(id), 0, 4294967294.0);
                 ids.push_back(static_cast<std::uint32_t>(id));
               }
               get(c) = std::move(ids);
             },
             [=](const Config& c) { return get(c) ? json(*get(c)) : json(); }),
      shown);
}

ConfigKey tokens_key() {
  return with_default(
      custom("auth", "token", "tables", "",
             "`[[auth.token]]` with `name`, `role`, `sha256`: bearer tokens, role "
             "viewer/technician/admin, SHA-256 hex of the token (`gonioctl token hash TOKEN`)",
             [](ObjectReader& r, Config& c) {
               const auto* toks = r.raw("token");
               if (!toks) return;
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
                   throw Error::invalid(t.path("sha256"), "must be 64 lower-case hex digits (the "
                                                          "SHA-256 of the token; `gonioctl token-hash`)");
                 t.finish();
                 c.tokens.push_back(std::move(e));
               }
             },
             [](const Config& c) {
               if (c.tokens.empty()) return json();
               json list = json::array();
               for (const auto& t : c.tokens)
                 list.push_back({{"name", t.name}, {"role", to_text(t.role)}, {"sha256", t.sha256}});
               return list;
             }),
      "—");
}

// [server.tls]: a file of the tls:// and https:// listeners, an absolute path. Whether it
// can be read, its mode and whether the certificate is current are checked when goniod
// loads it (net::check_tls_files, also run by --check-config), not when the file is parsed.
ConfigKey tls_file_key(std::string_view name, std::string Config::Tls::*m, std::string_view doc) {
  return with_default(then(text("server.tls", name, field(&Config::tls, m), doc),
                           [=](const Config& c) {
                             const auto& path = c.tls.*m;
                             if (!path.empty() && path.front() != '/')
                               throw Error::invalid(fmt::format("server.tls.{}", name),
                                                    fmt::format("'{}' must be an absolute path", path));
                           }),
                      "—");
}

}  // namespace

// [server]: listeners and their limits
void server_keys(std::vector<ConfigKey>& k) {
  using C = Config;
  k.push_back(listen_key());
  k.push_back(boolean("server", "allow_remote", field(&C::allow_remote),
                      "allow TCP/HTTP on non-loopback addresses"));
  k.push_back(integer("server", "io_threads", field(&C::io_threads), 1, 64, "network threads (an event loop each; a connection stays on one)"));
  k.push_back(integer("server", "rpc_threads", field(&C::rpc_threads), 1, 64,
                      "workers for blocking methods (instrument, twin, export)"));
  k.push_back(number("server", "client_share_busy", field(&C::client_share_busy), 0, 64,
                     "cores' worth of CPU for client requests while the scan runner waits for a "
                     "core (0: not governed); control methods are never held"));
  k.push_back(integer("server", "max_message_bytes", field(&C::max_message_bytes), 1024, 64ll << 20,
                      "largest message (line, HTTP body, WebSocket message)"));
  k.push_back(seconds("server", "read_timeout_s", field(&C::read_timeout), 0.1, 3600,
                      "a started message must complete within this (stalled peers are dropped)"));
  k.push_back(seconds("server", "idle_timeout_s", field(&C::idle_timeout), 0, 86400,
                      "drop idle connections after this (0: never; subscribers idle)"));
  k.push_back(integer("server", "max_queue", field(&C::max_queue), 1, 1 << 20,
                      "outgoing messages queued per connection; a peer that does not read is dropped"));
  k.push_back(integer("server", "max_connections", field(&C::max_connections), 1, 65536, "per listener"));
  k.push_back(integer("server", "max_queue_bytes", field(&C::max_queue_bytes), 64 << 10, 1ll << 30,
                      "outgoing bytes queued per connection (beyond: the peer is dropped as a slow reader)"));
  k.push_back(integer("server", "max_buffered_bytes", field(&C::max_buffered_bytes), 1 << 20, 16ll << 30,
                      "outgoing bytes queued over all connections (beyond: the peer adding more is "
                      "dropped; HTTP answers 503)"));
  k.push_back(seconds("server", "write_timeout_s", field(&C::write_timeout), 0.1, 3600,
                      "every write must complete within this, else the peer is dropped as a slow reader"));
  k.push_back(seconds("server", "login_timeout_s", field(&C::login_timeout), 0.1, 3600,
                      "TCP and WebSocket peers without a role must log in within this"));
  k.push_back(integer("server", "max_in_flight", field(&C::max_in_flight), 1, 1024,
                      "requests being handled per connection, each batch element counted (reading pauses)"));
  k.push_back(integer("server", "max_batch", field(&C::max_batch), 1, 100000,
                      "elements of one batch; more: one −32600 naming the limit"));
  k.push_back(integer("server", "max_response_bytes", field(&C::max_response_bytes), 64 << 10, 1ll << 30,
                      "one answer, single or batch; a call whose answer would pass it gets −32008 instead"));
  k.push_back(integer("server", "max_building_bytes", field(&C::max_building_bytes), 1 << 20, 16ll << 30,
                      "answers of batches still being assembled, over all connections; a batch "
                      "element whose answer does not fit gets −32010 in its place"));
  k.push_back(origins_key());
  k.push_back(with_default(
      custom("server", "web_root", "string", "",
             "the dashboard's files ([web/README.md](../web/README.md)), read once at start and "
             "served by `GET` on the HTTP listeners; an absolute path, `\"\"` for none. Not set: a "
             "build tree's goniod serves the tree's own (`<build>/web/dist`, beside `bin/`, when it "
             "holds an `index.html`) before the installed one; the log says at start which "
             "directory it serves. A missing directory serves no dashboard; more than 256 files or "
             "32 MiB is refused",
             [](ObjectReader& r, Config& c) {
               c.web_root_set = c.web_root_set || r.has("web_root");
               c.web_root = r.optional<std::string>("web_root", c.web_root);
               if (!c.web_root.empty() && c.web_root.front() != '/')
                 throw Error::invalid("server.web_root", fmt::format("'{}' must be an absolute path "
                                                                     "(or empty: no dashboard)",
                                                                     c.web_root));
             },
             [](const Config& c) { return json(c.web_root); }),
      "`/usr/share/gonio/web`"));
  k.push_back(one_of("server", "log_level", &C::log_level, {"trace", "debug", "info", "warn", "error"},
                     "one of trace, debug, info, warn, error", "how much goniod logs"));
}

void tls_keys(std::vector<ConfigKey>& k) {
  using T = Config::Tls;
  k.push_back(tls_file_key("cert", &T::cert,
                           "the `tls://` and `https://` listeners' certificate (PEM; intermediate "
                           "certificates after it), re-read on `SIGHUP`; refused when expired or "
                           "not yet valid"));
  k.push_back(tls_file_key("key", &T::key,
                           "… its private key (PEM), readable by its owner only (mode 0600 or 0400); "
                           "refused when it does not match the certificate"));
  k.push_back(tls_file_key("client_ca", &T::client_ca,
                           "CA certificates (PEM) that client certificates are verified against; "
                           "a client that presents none may still `auth.login`, one whose subject "
                           "CN is the name of a token gets that token's name and role (TLS in "
                           "[README](#tls))"));
}

// [auth]: tokens; [auth.unix]: the roles of Unix-socket peers
void auth_keys(std::vector<ConfigKey>& k) {
  using C = Config;
  k.push_back(tokens_key());
  k.push_back(ids_key("admin_uids", &C::UnixRoles::admin_uids, "`[0, goniod's uid]`",
                      "Unix-socket peers with one of these uids are admin"));
  k.push_back(ids_key("admin_gids", &C::UnixRoles::admin_gids, "`[]`",
                      "… or in one of these groups (primary or supplementary)"));
  k.push_back(ids_key("technician_uids", &C::UnixRoles::technician_uids, "`[]`",
                      "Unix-socket peers with one of these uids are technician"));
  k.push_back(ids_key("technician_gids", &C::UnixRoles::technician_gids, "`[goniod's gid]`",
                      "… or in one of these groups (the socket's group: lab members added for gonioctl)"));
  k.push_back(ids_key("viewer_uids", &C::UnixRoles::viewer_uids, "`[]`",
                      "Unix-socket peers with one of these uids are viewer"));
  k.push_back(ids_key("viewer_gids", &C::UnixRoles::viewer_gids, "`[]`",
                      "… or in one of these groups; a peer matching nothing must `auth.login`"));
}

}  // namespace gonio::daemon
