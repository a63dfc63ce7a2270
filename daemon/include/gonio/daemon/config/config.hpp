// goniod configuration: one TOML file (toml++), every key validated, unknown keys rejected.
//
// The file is converted to JSON and read with json_util::ObjectReader, so a bad key or
// value fails with the key's dotted path, the value and the allowed range
// ("divergence.z_threshold = 0 is outside the allowed range [0.5, 100]"). Every key is
// described once (ConfigKey, config_keys.cpp), and daemon/README.md's key table is made from
// those rows; daemon/examples/ holds a file for the mock and one for real hardware. Driver tables ([instrument.motion], [instrument.photometer]) are
// handed to the driver registry as JSON, which validates them in turn.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "gonio/drivers/motion/limits.hpp"
#include "gonio/proto/enum_text.hpp"
#include "gonio/twin/estimator_options.hpp"

namespace gonio::json_util {
class ObjectReader;
}

namespace gonio::daemon {

using std::chrono::milliseconds;

enum class Role : int { none = 0, viewer = 1, technician = 2, admin = 3 };
inline constexpr EnumNames<Role, 4> kRoleNames{{
    {Role::none, "none"},
    {Role::viewer, "viewer"},
    {Role::technician, "technician"},
    {Role::admin, "admin"},
}};
constexpr const auto& enum_names(Role) { return kRoleNames; }  // proto/enum_text.hpp
// "viewer" | "technician" | "admin"; throws Error naming `field`.
Role parse_role(std::string_view text, std::string_view field = "role");

// Where goniod listens: unix:PATH, tcp://HOST:PORT (NDJSON), http://HOST:PORT (HTTP + WS),
// and the same two over TLS: tls://HOST:PORT, https://HOST:PORT (HTTPS + WSS).
struct ListenUri {
  enum class Kind { unix_socket, tcp, http, tls, https };
  Kind kind = Kind::unix_socket;
  std::string path;  // unix
  std::string host;  // tcp, http, tls, https: a literal IPv4/IPv6 address or "localhost"
  std::uint16_t port = 0;  // 0: an ephemeral port (logged and written to <state-dir>/ports.json)

  // Throws Error(invalid_argument) naming `field`.
  static ListenUri parse(std::string_view text, std::string_view field = "listen");
  std::string to_string() const;
  bool loopback() const;  // host is 127.0.0.0/8, ::1 or localhost (always true for unix)
  bool tls() const { return kind == Kind::tls || kind == Kind::https; }
};

// The MQTT broker of [mqtt] url: mqtt://HOST:PORT (plain, port 1883 when left out) or
// mqtts://HOST:PORT (TLS, port 8883).
struct MqttUrl {
  bool tls = false;
  std::string host;
  std::uint16_t port = 1883;

  // Throws Error(invalid_argument) naming `field`.
  static MqttUrl parse(std::string_view text, std::string_view field = "mqtt.url");
  std::string to_string() const;
};

// An instrument id as it appears in MQTT topics and archive rows: 1..64 of [A-Za-z0-9._-].
// Throws Error(invalid_argument) naming `field`.
void check_instrument_id(std::string_view id, std::string_view field);
// This host's name, made an instrument id (other characters become '-'); "goniod" if none.
std::string default_instrument_id();

struct TokenEntry {
  std::string name;    // who, for the audit log
  Role role = Role::viewer;
  std::string sha256;  // lower-case hex SHA-256 of the token text
};

// The mock instrument's hidden true sample under `goniod --mock`, and the BSDF of the demo's
// catalog sample: a glossy orange paint (a diffuse base under a smooth clear coat).
inline constexpr const char* kDemoSampleBsdf =
    "lambert:albedo=400:0.06,500:0.12,600:0.45,700:0.55+coat:alpha=0.06,ior=1.5";

// Where the package installs the dashboard (web/): <datadir>/gonio/web.
std::string default_web_root();

// A build tree's own dashboard beside the executable `exe` (<build>/bin/goniod →
// <build>/web/dist) when that directory holds an index.html; else empty.
std::string web_root_beside(std::string_view exe);

struct Config {
  // Keys that still load but no longer do anything (logged at start).
  std::vector<std::string> warnings;

  // [server]
  std::vector<ListenUri> listen;  // empty: unix:<state-dir>/goniod.sock only
  bool allow_remote = false;      // tcp/http on a non-loopback address needs this
  int io_threads = 2;
  std::size_t max_message_bytes = 1 << 20;
  milliseconds read_timeout{10000};   // a started message must complete within this
  milliseconds idle_timeout{0};       // 0: connections may stay idle (subscribers)
  std::size_t max_queue = 1024;       // queued outgoing messages per connection
  std::size_t max_queue_bytes = 16u << 20;      // queued outgoing bytes per connection
  std::size_t max_buffered_bytes = 32u << 20;   // queued outgoing bytes over all connections
  milliseconds write_timeout{10000};  // a write must complete within this (else: slow reader)
  milliseconds login_timeout{10000};  // TCP/WebSocket peers must authenticate within this
  std::size_t max_in_flight = 16;     // requests (batch elements) being handled per connection
  std::size_t max_batch = 128;        // elements of one batch
  std::size_t max_response_bytes = 8u << 20;
  std::size_t max_building_bytes = 12u << 20;  // batch answers being assembled, over all connections
  std::vector<std::string> allowed_origins;  // browser origins besides the listener's own host
  // The dashboard's files, served on the HTTP listeners (empty: no dashboard). Unless the
  // file sets it (web_root_set), goniod serves a build tree's own beside its executable
  // first (served_web_root).
  std::string web_root = default_web_root();
  bool web_root_set = false;
  std::string served_web_root(std::string_view exe) const;
  std::size_t max_connections = 512;
  std::size_t rpc_threads = 2;        // workers for blocking methods
  // Client work's CPU, in cores, while the measurement waits for a core (rpc/governor.hpp);
  // 0: not governed.
  double client_share_busy = 0.05;
  std::string log_level = "info";
  // [server.tls]: the certificate (PEM, the chain after it) and key of the tls:// and
  // https:// listeners, re-read on SIGHUP; client_ca: client certificates are asked for and
  // verified against it, and one whose subject CN names a token gets that token's role.
  struct Tls {
    std::string cert, key, client_ca;
  } tls;

  // [auth]
  std::vector<TokenEntry> tokens;  // [[auth.token]] name, role, sha256
  // [auth.unix]: roles of Unix-socket peers by their uid and groups (primary and
  // supplementary). Unset lists take their defaults at start: admin_uids root and the
  // user goniod runs as, technician_gids goniod's group (the socket's). A peer that
  // matches nothing has no role and must auth.login like a TCP peer.
  struct UnixRoles {
    std::optional<std::vector<std::uint32_t>> admin_uids, admin_gids, technician_uids,
        technician_gids, viewer_uids, viewer_gids;
  } unix_roles;

  // [store]
  bool synchronous_full = true;  // "full": fsync every committed point; "normal": WAL default
  // Below this much free space in the state directory a `storage` warning is raised and no
  // new scan starts; a store made read-only by a full disk writes again above it (+ reserve).
  double min_free_mb = 64;
  // Points of finished scans older than this that the central archive has committed are
  // pruned (store/retention.hpp); 0: kept for ever.
  double retention_days = 0;

  // [instrument]
  std::string profile = "gcms4";  // preset name or JSON profile path
  nlohmann::json motion = nlohmann::json::object();      // [instrument.motion] driver table
  nlohmann::json photometer = nlohmann::json::object();  // [instrument.photometer]
  milliseconds move_timeout{60000};
  milliseconds home_timeout{120000};
  milliseconds measure_timeout{30000};
  milliseconds settle{0};
  // Auto-ranging (autorange.hpp): each point starts at integration_ms (unset: the
  // photometer's own setting when goniod first reads it), saturation shortens it down to
  // integration_min_ms, under-exposure lengthens it up to integration_max_ms. Off, or with a
  // photometer whose integration time is not settable, a saturated reading is a fault.
  bool autorange = true;
  std::optional<double> integration_ms;
  double integration_min_ms = 1;
  double integration_max_ms = 2000;
  double underexposed_snr = 10;
  // [instrument.limits]: the one table of soft limits and arm clearance, handed to the
  // driver registry, which guards the motion controller with it. An unset min_separation
  // takes the motion driver's default (the mock: its profile's arms.min_separation_deg).
  drivers::MotionLimits limits;
  bool auto_resume = false;
  milliseconds auto_resume_delay{30000};
  int max_auto_resumes = 3;
  // A device whose link failed is dropped and opened again after reconnect_initial, then
  // after twice the previous wait, at most reconnect_max.
  milliseconds reconnect_initial{500};
  milliseconds reconnect_max{30000};

  // [twin]
  unsigned twin_threads = 0;  // 0: hardware concurrency
  // The twin's own defaults (gonio-twin starts from the same).
  double twin_rel_se = twin::EstimatorOptions{}.rel_se;
  std::uint64_t twin_max_samples = twin::EstimatorOptions{}.max_samples;
  int twin_replicates = twin::EstimatorOptions{}.replicates;
  std::uint64_t twin_seed = 1;
  std::string twin_data_dir;  // '@file' BSDF specs from clients: only here (empty: <state-dir>/data)

  // [divergence]
  double coverage_k = 2.0;           // of the decision rule (docs/decision-rule.md)
  double z_threshold = 5.0;          // |m − p|/u_c beyond it flags a point "inconsistent"
  double delta_e_threshold = 3.0;    // the colour's acceptance limit (ΔE00)
  double delta_uv_threshold = 0.004; // ... and above β = 1 (Δu′v′)
  double reference_drift = 0.05;     // relative drift of the reference white reading
  bool pause_on_sustained = false;
  bool diagnose = true;              // refit the verdict's named cause through the inverse twin

  // [webhook]
  std::string webhook_url;  // http://HOST:PORT/PATH; empty: no webhook
  int webhook_retries = 5;
  milliseconds webhook_backoff{500};
  milliseconds webhook_timeout{5000};
  std::string webhook_min_severity = "warning";

  // [mqtt] telemetry (docs/architecture.md §11); off while url is empty.
  struct Mqtt {
    std::string url;         // mqtt://HOST:PORT or mqtts://HOST:PORT
    std::string instrument;  // empty: default_instrument_id()
    std::string username, password;
    int qos = 1;
    std::string topic_prefix = "gonio";
    std::string ca_file, cert_file, key_file;  // mqtts: CA (empty: the system's), client cert
    std::size_t queue = 10000;                 // messages waiting for the broker, at most
    int keepalive_s = 30;
  } mqtt;

  // [archive] the central PostgreSQL archive (docs/architecture.md §11); off while postgres
  // is empty.
  struct Archive {
    std::string postgres;    // libpq connection string or URI
    std::string instrument;  // empty: default_instrument_id()
    std::size_t batch = 500;             // outbox rows per PostgreSQL transaction
    milliseconds retry_max{10000};       // back-off cap while the server is unreachable
    milliseconds max_backlog_age{600000};  // older unshipped rows raise a warning alert
  } archive;

  // The built-in mock instrument (goniod --mock): instrument.motion and .photometer both
  // {"driver": "mock"} with the drivers' defaults.
  static Config mock_defaults();
  // Throws Error naming "<source>:<line>" for TOML syntax errors, the key path otherwise.
  static Config parse(std::string_view toml_text, std::string_view source = "<config>",
                      const std::optional<Config>& base = std::nullopt);
  static Config load(const std::string& path, const std::optional<Config>& base = std::nullopt);
  // Checks cross-field rules (loopback unless allow_remote).
  void validate() const;
  // Every key of the file with the value in effect, defaults filled in, in the file's units
  // and layout ([server], [instrument.limits], ...): what goniod --check-config prints.
  // Config::parse of its TOML text (to_toml) gives this Config back.
  nlohmann::json to_json() const;
};

// One key of the file, described once (config_keys.cpp): Config::parse reads the file by
// these rows, to_json prints by them, and daemon/README.md's key table is made from them
// (config_key_table; a unit test holds the README to it).
struct ConfigKey {
  using Reader = std::function<void(json_util::ObjectReader& section, Config& into)>;
  // The value in effect, null when unset (a default decided at start: not printed).
  using Writer = std::function<nlohmann::json(const Config&)>;
  std::string_view section;  // "server", "auth.unix", "instrument.limits"
  std::string_view name;
  std::string_view type;     // as the README shows it: bool, integer, number, seconds, ...
  std::string range;         // the allowed values ("1–64"); empty: any of its type
  std::string_view default_text;  // the README's default when not the value of Config{}
  std::string_view doc;      // Markdown, the README's "meaning"
  Reader read;               // reads and checks the key, naming it in errors
  Writer write;
};
// Every key, in the file's order: each section's keys before the sections inside it.
std::span<const ConfigKey> config_keys();
// The Markdown table of daemon/README.md's "Configuration" section.
std::string config_key_table();

// TOML document → JSON (tables → objects, arrays → arrays, dates → ISO strings).
nlohmann::json toml_to_json(std::string_view toml_text, std::string_view source);
// JSON object → TOML document text, the way back for what toml_to_json gives.
std::string json_to_toml(const nlohmann::json& doc);

}  // namespace gonio::daemon
