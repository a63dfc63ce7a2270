// goniod configuration: every key validated, unknown keys rejected, examples parse.
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "gonio/daemon/config/config.hpp"
#include "gonio/drivers/modbus/modbus_motion.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {
namespace {

std::string field_of(std::string_view toml) {
  try {
    (void)Config::parse(toml, "test.toml");
  } catch (const Error& e) {
    return e.field();
  }
  return "<no error>";
}

TEST(Config, DefaultsWhenEmpty) {
  const auto c = Config::parse("", "empty.toml");
  EXPECT_TRUE(c.listen.empty());
  EXPECT_DOUBLE_EQ(c.z_threshold, 5.0);
  EXPECT_EQ(c.read_timeout, std::chrono::milliseconds(10000));
  EXPECT_TRUE(c.synchronous_full);
}

TEST(Config, ReadsEveryTable) {
  const auto c = Config::parse(R"(
[server]
listen = ["tcp://127.0.0.1:7700", "http://[::1]:0", "unix:/run/x.sock"]
read_timeout_s = 0.5
max_queue = 8
[store]
synchronous = "normal"
[instrument]
move_timeout_s = 2
[instrument.limits]
incidence = [0, 70]
rotation = [-180, 270]
tilt = [-5, 5]
min_separation = 4
[instrument.motion]
driver = "mock"
time_scale = 0.5
[instrument.photometer]
driver = "mock"
[divergence]
z_threshold = 3
coverage_k = 3
sustained_m = 2
sustained_n = 4
[[auth.token]]
name = "v"
role = "viewer"
sha256 = "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
[webhook]
url = "http://127.0.0.1:9/hook"
backoff_s = 0.05
)",
                               "full.toml");
  ASSERT_EQ(c.listen.size(), 3u);
  EXPECT_EQ(c.listen[0].kind, ListenUri::Kind::tcp);
  EXPECT_EQ(c.listen[0].port, 7700);
  EXPECT_EQ(c.listen[1].host, "::1");
  EXPECT_EQ(c.listen[1].to_string(), "http://[::1]:0");
  EXPECT_EQ(c.listen[2].path, "/run/x.sock");
  EXPECT_EQ(c.read_timeout, std::chrono::milliseconds(500));
  EXPECT_EQ(c.max_queue, 8u);
  EXPECT_FALSE(c.synchronous_full);
  EXPECT_EQ(c.move_timeout, std::chrono::milliseconds(2000));
  EXPECT_DOUBLE_EQ(c.limits.incidence_max, 70);
  EXPECT_DOUBLE_EQ(c.limits.receive_min, -85);  // default
  EXPECT_EQ(c.limits.of(drivers::Axis::rotation), (drivers::SoftLimits{-180, 270}));
  EXPECT_EQ(c.limits.of(drivers::Axis::tilt), (drivers::SoftLimits{-5, 5}));
  EXPECT_DOUBLE_EQ(c.limits.min_separation.value(), 4);
  EXPECT_EQ(c.motion["time_scale"], 0.5);
  EXPECT_DOUBLE_EQ(c.coverage_k, 3);
  // The m-of-n window's keys still load, with a warning that they do nothing.
  ASSERT_EQ(c.warnings.size(), 2u);
  EXPECT_NE(c.warnings[0].find("divergence.sustained_m is no longer used"), std::string::npos);
  ASSERT_EQ(c.tokens.size(), 1u);
  EXPECT_EQ(c.tokens[0].role, Role::viewer);
  EXPECT_EQ(c.webhook_backoff, std::chrono::milliseconds(50));
}

TEST(Config, RejectsUnknownKeysAndBadValuesNamingThem) {
  EXPECT_EQ(field_of("[server]\nlisten_on = []\n"), "server.listen_on");
  EXPECT_EQ(field_of("[serv]\n"), "serv");
  EXPECT_EQ(field_of("[server]\nio_threads = 0\n"), "server.io_threads");
  EXPECT_EQ(field_of("[server]\nlisten = [\"ftp://x:1\"]\n"), "server.listen[0]");
  EXPECT_EQ(field_of("[server]\nlisten = [\"tcp://192.168.1.4:7700\"]\n"), "server.listen[0]");
  EXPECT_EQ(field_of("[server]\nlog_level = \"chatty\"\n"), "server.log_level");
  EXPECT_EQ(field_of("[divergence]\nz_threshold = 0\n"), "divergence.z_threshold");
  EXPECT_EQ(field_of("[divergence]\ncoverage_k = 0\n"), "divergence.coverage_k");
  EXPECT_EQ(field_of("[divergence]\ncoverage_k = -2\n"), "divergence.coverage_k");
  EXPECT_EQ(field_of("[divergence]\ndelta_uv_threshold = 1\n"), "divergence.delta_uv_threshold");
  EXPECT_EQ(field_of("[instrument.limits]\nreceive = [10, -10]\n"), "instrument.limits.receive[1]");
  EXPECT_EQ(field_of("[instrument.limits]\ntilt = [-400, 0]\n"), "instrument.limits.tilt[0]");
  EXPECT_EQ(field_of("[instrument.limits]\nmin_separation = 180\n"), "instrument.limits.min_separation");
  EXPECT_EQ(field_of("[instrument]\nmotion = { port = 3 }\n"), "instrument.motion");
  EXPECT_EQ(field_of("[[auth.token]]\nname = \"x\"\nrole = \"root\"\nsha256 = \"\"\n"), "auth.token[0].role");
  EXPECT_EQ(field_of("[[auth.token]]\nname = \"x\"\nrole = \"admin\"\nsha256 = \"abc\"\n"),
            "auth.token[0].sha256");
  EXPECT_EQ(field_of("[webhook]\nurl = \"https://x/\"\n"), "webhook.url");
  EXPECT_EQ(field_of("[store]\nsynchronous = \"sometimes\"\n"), "store.synchronous");
  EXPECT_EQ(field_of("[instrument]\nintegration_min_ms = 0\n"), "instrument.integration_min_ms");
  EXPECT_EQ(field_of("[instrument]\nintegration_min_ms = 10\nintegration_max_ms = 5\n"),
            "instrument.integration_max_ms");
  EXPECT_EQ(field_of("[instrument]\nintegration_ms = 5000\n"), "instrument.integration_ms");
  EXPECT_EQ(field_of("[instrument]\nautorange = 1\n"), "instrument.autorange");
  EXPECT_EQ(field_of("server = 3\n"), "server");
  EXPECT_EQ(field_of("[server\n"), "config");  // TOML syntax error
}

TEST(Config, ReconnectBackOffIsBoundedAndOrdered) {
  const auto d = Config::parse("");
  EXPECT_EQ(d.reconnect_initial, std::chrono::milliseconds(500));
  EXPECT_EQ(d.reconnect_max, std::chrono::milliseconds(30000));
  const auto c = Config::parse("[instrument]\nreconnect_initial_s = 2\nreconnect_max_s = 120\n");
  EXPECT_EQ(c.reconnect_initial, std::chrono::milliseconds(2000));
  EXPECT_EQ(c.reconnect_max, std::chrono::milliseconds(120000));
  EXPECT_EQ(field_of("[instrument]\nreconnect_initial_s = 0\n"), "instrument.reconnect_initial_s");
  EXPECT_EQ(field_of("[instrument]\nreconnect_initial_s = 5\nreconnect_max_s = 1\n"),
            "instrument.reconnect_max_s");
}

TEST(Config, ABuildTreesGoniodServesItsOwnDashboardUnlessWebRootIsSet) {
  namespace fs = std::filesystem;
  const auto tree = fs::temp_directory_path() / fmt::format("gonio-web-root-test-{}", ::getpid());
  fs::remove_all(tree);
  fs::create_directories(tree / "bin");
  fs::create_directories(tree / "web" / "dist");
  const auto exe = (tree / "bin" / "goniod").string();
  const auto dist = (tree / "web" / "dist").string();
  // Without an index.html the directory is not a dashboard.
  EXPECT_EQ(web_root_beside(exe), "");
  EXPECT_EQ(Config{}.served_web_root(exe), default_web_root());
  std::ofstream(tree / "web" / "dist" / "index.html") << "<!doctype html>";
  EXPECT_EQ(web_root_beside(exe), dist);
  EXPECT_EQ(web_root_beside(""), "");
  const auto unset = Config::parse("[server]\nlog_level = \"info\"\n", "t.toml");
  EXPECT_FALSE(unset.web_root_set);
  EXPECT_EQ(unset.served_web_root(exe), dist);
  // Set, even to the installed directory or to none: as set.
  for (const std::string& root : {std::string("/srv/gonio-web"), default_web_root(), std::string()}) {
    const auto c = Config::parse(fmt::format("[server]\nweb_root = \"{}\"\n", root), "t.toml");
    EXPECT_TRUE(c.web_root_set);
    EXPECT_EQ(c.served_web_root(exe), root);
  }
  fs::remove_all(tree);
}

TEST(Config, WebRootIsTheInstalledDashboardAnAbsolutePathOrNone) {
  EXPECT_EQ(Config{}.web_root, default_web_root());
  EXPECT_TRUE(default_web_root().ends_with("/gonio/web")) << default_web_root();
  EXPECT_EQ(Config::parse("[server]\nweb_root = \"/srv/gonio-web\"\n", "t.toml").web_root, "/srv/gonio-web");
  EXPECT_EQ(Config::parse("[server]\nweb_root = \"\"\n", "t.toml").web_root, "");
  EXPECT_EQ(field_of("[server]\nweb_root = \"web/dist\"\n"), "server.web_root");
}

TEST(Config, RemoteListenNeedsOptIn) {
  const auto c = Config::parse("[server]\nallow_remote = true\nlisten = [\"tcp://0.0.0.0:7700\"]\n");
  EXPECT_FALSE(c.listen[0].loopback());
  EXPECT_TRUE(ListenUri::parse("tcp://127.0.0.2:1").loopback());
  EXPECT_TRUE(ListenUri::parse("unix:/x").loopback());
}

TEST(Config, TlsListenersNeedACertificateAndItsKey) {
  const auto c = Config::parse("[server]\nlisten = [\"tls://127.0.0.1:7443\", \"https://[::1]:8443\"]\n"
                               "[server.tls]\ncert = \"/etc/gonio/tls/goniod.pem\"\nkey = \"/etc/gonio/tls/goniod.key\"\n");
  ASSERT_EQ(c.listen.size(), 2u);
  EXPECT_EQ(c.listen[0].kind, ListenUri::Kind::tls);
  EXPECT_EQ(c.listen[1].to_string(), "https://[::1]:8443");
  EXPECT_TRUE(c.listen[1].tls() && c.listen[1].loopback());
  EXPECT_EQ(c.tls.key, "/etc/gonio/tls/goniod.key");
  // Files are checked when goniod loads them (net::check_tls_files), not when parsed.
  EXPECT_EQ(field_of("[server]\nlisten = [\"tls://127.0.0.1:7443\"]\n"), "server.listen[0]");
  EXPECT_EQ(field_of("[server.tls]\ncert = \"/c.pem\"\n"), "server.tls.key");
  EXPECT_EQ(field_of("[server.tls]\ncert = \"c.pem\"\nkey = \"/k.pem\"\n"), "server.tls.cert");
  EXPECT_EQ(field_of("[server.tls]\nclient_ca = \"/ca.pem\"\n"), "server.tls.client_ca");
  EXPECT_EQ(field_of("[server.tls]\ncertificate = \"/c.pem\"\n"), "server.tls.certificate");
}

TEST(Config, ExamplesParseAndTheirDriverTablesAreValid) {
  const auto mock = Config::load(GONIO_SOURCE_DIR "/daemon/examples/goniod-mock.toml");
  EXPECT_EQ(mock.motion["driver"], "mock");
  EXPECT_EQ(mock.listen.size(), 2u);
  const auto hw = Config::load(GONIO_SOURCE_DIR "/daemon/examples/goniod-hardware.toml");
  EXPECT_EQ(hw.motion["driver"], "modbus");
  EXPECT_EQ(hw.photometer["driver"], "scpi-serial");
  // The Modbus table must be one the driver accepts (it opens no port to parse it).
  auto table = hw.motion;
  table.erase("driver");
  const auto mc = drivers::modbus::MotionConfig::from_json(table);
  EXPECT_EQ(mc.axes.size(), 2u);
  // Its soft limits are in the one limits table.
  EXPECT_EQ(hw.limits.of(drivers::Axis::incidence), (drivers::SoftLimits{0, 80}));
  EXPECT_DOUBLE_EQ(hw.limits.min_separation.value(), 8);
}

TEST(Config, OldModbusLimitKeysAreRefusedWithWhereTheyLiveNow) {
  // A config written for the per-axis driver limits still parses as TOML; the driver table
  // is refused with the key and the new home of soft limits.
  const auto c = Config::parse(R"(
[instrument.motion]
driver = "modbus"
[instrument.motion.links.bus]
type = "rtu"
device = "/dev/null"
[instrument.motion.axes.incidence]
unit = 1
steps_per_degree = 1000
min_deg = 0
max_deg = 80
[instrument.photometer]
driver = "mock"
)");
  auto table = c.motion;
  table.erase("driver");
  try {
    drivers::modbus::MotionConfig::from_json(table);
    FAIL() << "per-axis limits were accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::invalid_argument);
    EXPECT_EQ(e.field(), "axes.incidence.min_deg");
    EXPECT_NE(std::string(e.what()).find("[instrument.limits]"), std::string::npos) << e.what();
  }
}

TEST(Config, MockDefaultsUseTheDemoSample) {
  const auto c = Config::mock_defaults();
  EXPECT_EQ(c.motion["driver"], "mock");
  EXPECT_EQ(c.motion["sample"], kDemoSampleBsdf);
  EXPECT_EQ(c.photometer["driver"], "mock");
}

// What goniod --check-config prints is the Config itself: its TOML reads back to the same
// Config, with every key present, for both examples and for values that need care (0.05 is
// not exactly representable; strings need escapes; tokens are an array of tables).
TEST(Config, EffectiveConfigRoundTripsThroughToml) {
  auto tricky = Config::parse(R"(
[server]
listen = ["unix:/run/gonio/a \"b\".sock"]
[instrument]
settle_s = 0.05
[instrument.limits]
receive = [-82.123456789, 82]
[instrument.motion]
driver = "mock"
[instrument.photometer]
driver = "mock"
[[auth.token]]
name = "lab-viewer"
role = "viewer"
sha256 = "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
[divergence]
reference_drift = 0.05
)", "tricky.toml");
  for (const auto& c : {Config::load(GONIO_SOURCE_DIR "/daemon/examples/goniod-mock.toml"),
                        Config::load(GONIO_SOURCE_DIR "/daemon/examples/goniod-hardware.toml"),
                        tricky, Config{}}) {
    const auto text = json_to_toml(c.to_json());
    SCOPED_TRACE(text);
    const auto back = Config::parse(text, "effective.toml");
    EXPECT_EQ(back.to_json(), c.to_json());
  }
  const auto text = json_to_toml(tricky.to_json());
  EXPECT_NE(text.find("reference_drift = 0.05\n"), std::string::npos);
  EXPECT_NE(text.find("receive = [-82.123456789, 82.0]\n"), std::string::npos);
  EXPECT_NE(text.find("[[auth.token]]\n"), std::string::npos);
  // Every key of every table, defaults included.
  const auto doc = Config{}.to_json();
  for (const char* key : {"listen", "allow_remote", "io_threads", "rpc_threads", "max_message_bytes",
                          "read_timeout_s", "idle_timeout_s", "max_queue", "max_connections", "web_root", "log_level"})
    EXPECT_TRUE(doc["server"].contains(key)) << key;
  EXPECT_EQ(doc["instrument"]["limits"]["incidence"], nlohmann::json::array({0.0, 85.0}));
  EXPECT_EQ(doc["webhook"]["min_severity"], "warning");
}

// ---- the [mqtt] and [archive] sections

void expect_config_error(const std::string& toml, const std::string& field, const std::string& text = {}) {
  try {
    (void)Config::parse(toml, "test.toml");
    ADD_FAILURE() << "accepted: " << toml;
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), field) << e.what();
    if (!text.empty()) {
      EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
    }
  }
}

TEST(ArchiveConfig, BothOffByDefaultAndReadWhenGiven) {
  const auto d = Config::parse("");
  EXPECT_TRUE(d.mqtt.url.empty());
  EXPECT_TRUE(d.archive.postgres.empty());
  const auto c = Config::parse(R"(
[mqtt]
url = "mqtts://broker.lab:8884"
instrument = "gcms-2"
username = "gonio"
password = "pw"
qos = 2
topic_prefix = "lab/gonio"
ca_file = "/etc/ssl/lab-ca.pem"
cert_file = "/etc/gonio/client.pem"
key_file = "/etc/gonio/client.key"
queue = 500
keepalive_s = 10

[archive]
postgres = "host=db.lab dbname=gonio"
instrument = "gcms-2"
batch = 1000
retry_max_s = 30
max_backlog_age_s = 3600
)");
  EXPECT_EQ(c.mqtt.qos, 2);
  EXPECT_EQ(c.mqtt.queue, 500u);
  EXPECT_EQ(c.mqtt.topic_prefix, "lab/gonio");
  const auto u = MqttUrl::parse(c.mqtt.url);
  EXPECT_TRUE(u.tls);
  EXPECT_EQ(u.host, "broker.lab");
  EXPECT_EQ(u.port, 8884);
  EXPECT_EQ(c.archive.batch, 1000u);
  EXPECT_EQ(c.archive.retry_max, std::chrono::seconds(30));
  EXPECT_EQ(c.archive.max_backlog_age, std::chrono::hours(1));
  // --check-config's effective configuration parses back to the same.
  const auto back = Config::parse(json_to_toml(c.to_json()));
  EXPECT_EQ(back.mqtt.url, c.mqtt.url);
  EXPECT_EQ(back.archive.postgres, c.archive.postgres);
  EXPECT_EQ(back.archive.max_backlog_age, c.archive.max_backlog_age);
}

TEST(ArchiveConfig, TheEffectiveConfigurationShowsNoSecrets) {
  const auto c = Config::parse(R"(
[mqtt]
url = "mqtt://broker.lab:1883"
username = "gonio"
password = "mqtt-secret"

[archive]
postgres = "host=db.lab password='pg secret' dbname=gonio"
)");
  const auto shown = c.to_json().dump();
  EXPECT_EQ(shown.find("mqtt-secret"), std::string::npos) << shown;
  EXPECT_EQ(shown.find("pg secret"), std::string::npos) << shown;
  EXPECT_EQ(c.to_json()["archive"]["postgres"], "host=db.lab password=*** dbname=gonio");
  const auto uri = Config::parse("[archive]\npostgres = \"postgresql://gonio:s3cret@db.lab/gonio\"\n");
  EXPECT_EQ(uri.to_json()["archive"]["postgres"], "postgresql://gonio:***@db.lab/gonio");
}

TEST(ArchiveConfig, BadValuesNameTheKeyAndTheAllowedRange) {
  expect_config_error("[mqtt]\nurl = \"http://x:1\"\n", "mqtt.url", "mqtt://HOST:PORT");
  expect_config_error("[mqtt]\nurl = \"mqtt://x:0\"\n", "mqtt.url", "1..65535");
  expect_config_error("[mqtt]\nurl = \"mqtt://x\"\nqos = 3\n", "mqtt.qos", "[0, 2]");
  expect_config_error("[mqtt]\nurl = \"mqtt://x\"\nqueue = 1\n", "mqtt.queue");
  expect_config_error("[mqtt]\nurl = \"mqtt://x\"\ninstrument = \"a/b\"\n", "mqtt.instrument", "A-Z a-z 0-9");
  expect_config_error("[mqtt]\nurl = \"mqtt://x\"\ntopic_prefix = \"gonio/#\"\n", "mqtt.topic_prefix");
  expect_config_error("[mqtt]\nurl = \"mqtt://x\"\nca_file = \"/ca.pem\"\n", "mqtt.url", "mqtts://");
  expect_config_error("[mqtt]\nurl = \"mqtts://x\"\ncert_file = \"/c.pem\"\n", "mqtt.key_file");
  expect_config_error("[mqtt]\ninstrument = \"a\"\n", "mqtt.url", "required");
  expect_config_error("[mqtt]\nurl = \"mqtt://x\"\nbroker = 1\n", "mqtt.broker");
  expect_config_error("[archive]\npostgres = \"host=x\"\nbatch = 0\n", "archive.batch", "[1, 5000]");
  expect_config_error("[archive]\npostgres = \"host=x\"\nmax_backlog_age_s = 0\n", "archive.max_backlog_age_s");
  expect_config_error("[archive]\npostgres = \"host=x\"\ninstrument = \"\"\nretry_max_s = 0\n",
                      "archive.retry_max_s");
  expect_config_error("[archive]\ninstrument = \"a\"\n", "archive.postgres", "required");
  expect_config_error("[archive]\npostgres = \"host=x\"\ninstrument = \"a b\"\n", "archive.instrument");
}

TEST(ArchiveConfig, DefaultInstrumentIdIsAValidId) {
  EXPECT_NO_THROW(check_instrument_id(default_instrument_id(), "instrument"));
}

}  // namespace
}  // namespace gonio::daemon
