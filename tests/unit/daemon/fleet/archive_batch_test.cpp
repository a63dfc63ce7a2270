// The pieces of MQTT telemetry and the central archive that need no server: the outbox
// (written with what it mirrors, in order, only while on), the archive batch (upserts,
// each record once, points in order, chunked), PostgreSQL array literals, MQTT topics and
// routing, and the [mqtt] / [archive] configuration.
#include <unistd.h>

#include <filesystem>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "gonio/daemon/config/config.hpp"
#include "gonio/daemon/fleet/archive.hpp"
#include "gonio/daemon/fleet/mqtt.hpp"
#include "gonio/daemon/store/store.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/point.hpp"

namespace gonio::daemon {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using Kind = OutboxRow::Kind;

class OutboxTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / fmt::format("gonio-outbox-test-{}-{}", ::getpid(),
                                                    ::testing::UnitTest::GetInstance()->random_seed());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  static ScanPlan plan(std::int64_t sample, std::size_t n) {
    ScanPlan p;
    p.sample_id = sample;
    for (std::size_t i = 0; i < n; ++i) p.geometries.push_back(Geometry::in_plane(45, 5.0 * static_cast<double>(i)));
    return p;
  }
  static PointRecord point(std::int64_t scan, std::int64_t index) {
    PointRecord p;
    p.scan_id = scan;
    p.index = index;
    p.geometry_index = index;
    p.planned = p.actual = Geometry::in_plane(45, 5.0 * static_cast<double>(index));
    p.started_at = p.finished_at = utc::now();
    p.measured = Spectrum(WavelengthGrid::parse("400:700:10"), std::vector<double>(31, 0.5),
                          std::vector<double>(31, 0.01));
    p.predicted = p.measured;
    p.twin_version = "profile=gcms4";
    p.z_max = 0.5;
    p.flags = {"reference_read", "odd \"flag\""};
    return p;
  }
  fs::path dir_;
};

TEST_F(OutboxTest, OffByDefaultSoAStoreWithoutAnArchiveWritesNone) {
  Store s(dir_ / "goniod.db");
  const auto sample = s.create_sample(SampleSpec{"tile", "", std::nullopt, 0.02}, "test");
  const auto sc = s.insert_scan(plan(sample.id, 2), false, "test");
  s.insert_point(point(sc.id, 0));
  EXPECT_EQ(s.outbox_stats().rows, 0);
  EXPECT_TRUE(s.outbox_batch(100).empty());
}

TEST_F(OutboxTest, EveryCommittedChangeIsQueuedInCommitOrderAndLeavesOnlyWhenRemoved) {
  Store s(dir_ / "goniod.db");
  s.set_outbox(true);
  int woken = 0;
  s.set_outbox_listener([&] { ++woken; });
  const auto sample = s.create_sample(SampleSpec{"tile", "", std::nullopt, 0.02}, "test");
  const auto sc = s.insert_scan(plan(sample.id, 3), false, "test");
  s.set_scan_state(sc.id, ScanState::running, "", "test");
  for (int i = 0; i < 3; ++i) s.insert_point(point(sc.id, i));
  AlertDraft d;
  d.kind = "divergence";
  d.dedup_key = "k";
  d.message = "m";
  const auto a = s.raise_alert(d);
  s.ack_alert(a.id, "tech");
  s.set_scan_state(sc.id, ScanState::completed, "", "test");
  EXPECT_EQ(woken, 9);

  const auto rows = s.outbox_batch(100);
  ASSERT_EQ(rows.size(), 9u);
  const std::vector<Kind> kinds{Kind::sample, Kind::scan, Kind::scan, Kind::point, Kind::point,
                                Kind::point, Kind::alert, Kind::alert, Kind::scan};
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i].kind, kinds[i]) << i;
    if (i) {
      EXPECT_GT(rows[i].seq, rows[i - 1].seq);
    }
  }
  EXPECT_EQ(rows[1].detail["state"], "queued");
  EXPECT_EQ(rows[2].detail["state"], "running");
  EXPECT_EQ(rows[8].detail["state"], "completed");
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(rows[3 + i].ref, sc.id);
    EXPECT_EQ(rows[3 + i].idx, i);
    const auto stored = json::parse(rows[3 + i].point_json).get<PointRecord>();  // joined
    EXPECT_EQ(stored.scan_id, sc.id);
    EXPECT_EQ(stored.index, i);
  }
  EXPECT_EQ(s.outbox_stats().rows, 9);
  EXPECT_EQ(s.outbox_stats().oldest_at, rows.front().at);

  // The batch after the first four (what the shipper reads ahead) is the rest, in order.
  const auto first = s.outbox_batch(4);
  const auto ahead = s.outbox_batch(3, first.back().seq);
  ASSERT_EQ(ahead.size(), 3u);
  for (std::size_t i = 0; i < ahead.size(); ++i) EXPECT_EQ(ahead[i].seq, rows[4 + i].seq);
  // A batch of the first four leaves; the rest stay in order.
  s.outbox_remove(first.front().seq, first.back().seq);
  const auto rest = s.outbox_batch(100);
  ASSERT_EQ(rest.size(), 5u);
  EXPECT_EQ(rest.front().seq, rows[4].seq);
  EXPECT_EQ(s.outbox_stats().rows, 5);
}

TEST_F(OutboxTest, AFailedPointWritesNoOutboxRowAndSeqsAreNeverReused) {
  Store s(dir_ / "goniod.db");
  s.set_outbox(true);
  const auto sample = s.create_sample(SampleSpec{"tile", "", std::nullopt, 0.02}, "test");
  const auto sc = s.insert_scan(plan(sample.id, 2), false, "test");
  s.insert_point(point(sc.id, 0));
  EXPECT_THROW(s.insert_point(point(sc.id, 0)), Error);  // twice: refused, rolled back whole
  auto rows = s.outbox_batch(100);
  ASSERT_EQ(rows.size(), 3u);
  const auto last = rows.back().seq;
  s.outbox_remove(rows.front().seq, last);
  s.insert_point(point(sc.id, 1));
  rows = s.outbox_batch(100);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_GT(rows.front().seq, last);
}

TEST_F(OutboxTest, ReshipQueuesTheSampleTheScanAndEveryPoint) {
  Store s(dir_ / "goniod.db");
  const auto sample = s.create_sample(SampleSpec{"tile", "", std::nullopt, 0.02}, "test");
  const auto sc = s.insert_scan(plan(sample.id, 4), false, "test");
  for (int i = 0; i < 4; ++i) s.insert_point(point(sc.id, i));
  s.set_outbox(true);  // an archive configured after the scan was measured
  EXPECT_EQ(s.outbox_reship(sc.id, "tech"), 6u);
  const auto rows = s.outbox_batch(100);
  ASSERT_EQ(rows.size(), 6u);
  EXPECT_EQ(rows[0].kind, Kind::sample);
  EXPECT_EQ(rows[1].kind, Kind::scan);
  EXPECT_TRUE(rows[1].detail.is_null());  // no state change to record
  for (int i = 0; i < 4; ++i) EXPECT_EQ(rows[2 + i].idx, i);
  try {
    s.outbox_reship(999, "tech");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::not_found);
  }
}

// ---- the archive batch

ArchiveInput input_with(std::size_t points, bool twice = false) {
  ArchiveInput in;
  Sample sm;
  sm.id = 7;
  sm.spec = SampleSpec{"tile", "", std::nullopt, 0.02};
  sm.created_at = "2026-01-01T00:00:00Z";
  in.samples.emplace(7, sm);
  Scan sc;
  sc.id = 3;
  sc.plan.sample_id = 7;
  sc.plan.geometries.push_back(Geometry::in_plane(45, 0));
  sc.state = ScanState::running;
  sc.submitted_at = "2026-01-01T00:00:00Z";
  in.scans.emplace(3, sc);
  std::int64_t seq = 1;
  in.rows.push_back({seq++, Kind::scan, 3, 0, "2026-01-01T00:00:01Z", json{{"state", "running"}, {"reason", ""}}, ""});
  for (std::size_t pass = 0; pass < (twice ? 2u : 1u); ++pass)
    for (std::size_t i = 0; i < points; ++i) {
      PointRecord p;
      p.scan_id = 3;
      p.index = static_cast<std::int64_t>(i);
      p.planned = p.actual = Geometry::in_plane(45, 0);
      p.started_at = p.finished_at = "2026-01-01T00:00:02Z";
      p.measured = Spectrum(WavelengthGrid::parse("400:700:10"), std::vector<double>(31, 0.25),
                            std::vector<double>(31, 0.5));
      in.rows.push_back({seq++, Kind::point, 3, p.index, "2026-01-01T00:00:02Z", nullptr, json(p).dump()});
    }
  in.rows.push_back({seq++, Kind::scan, 3, 0, "2026-01-01T00:00:03Z", json{{"state", "completed"}, {"reason", ""}}, ""});
  return in;
}

std::size_t count(const std::string& s, std::string_view what) {
  std::size_t n = 0;
  for (auto at = s.find(what); at != std::string::npos; at = s.find(what, at + 1)) ++n;
  return n;
}

TEST(ArchiveBatch, UpsertsParentsFirstEachOnceThenHistoryAndPointsInOrder) {
  const auto st = build_archive_batch("gcms-a", "1.2.3", input_with(3));
  ASSERT_EQ(st.size(), 5u);
  EXPECT_TRUE(st[0].sql.starts_with("INSERT INTO instruments"));
  EXPECT_TRUE(st[1].sql.starts_with("INSERT INTO samples"));
  EXPECT_TRUE(st[2].sql.starts_with("INSERT INTO scans"));
  EXPECT_TRUE(st[3].sql.starts_with("INSERT INTO scan_states"));
  EXPECT_TRUE(st[4].sql.starts_with("INSERT INTO points"));
  EXPECT_EQ(st[2].params.size(), 14u);       // one scan row although three outbox rows name it
  EXPECT_EQ(st[3].params.size(), 2u * 6u);   // two state changes
  EXPECT_EQ(st[4].params.size(), 3u * 23u);  // three points
  EXPECT_NE(st[4].sql.find("ON CONFLICT (instrument, scan_id, idx) DO NOTHING"), std::string::npos);
  for (const auto& s : st) {
    EXPECT_NE(s.sql.find("ON CONFLICT"), std::string::npos) << s.sql;  // idempotent, all
    for (std::size_t i = 0; i < s.params.size(); i += s.params.size() / std::max<std::size_t>(1, count(s.sql, "),(") + 1))
      EXPECT_EQ(s.params[i], std::optional<std::string>("gcms-a")) << s.sql;  // keyed by instrument
  }
  // Points in outbox order: idx is the third column of each row.
  for (std::size_t i = 0; i < 3; ++i) EXPECT_EQ(st[4].params[i * 23 + 2], std::to_string(i));
  EXPECT_EQ(st[4].params[13], pg_float_array(std::vector<double>(31, 0.25)));  // measured
  EXPECT_FALSE(st[4].params[15].has_value());  // no prediction: NULL
}

TEST(ArchiveBatch, APointTwiceInOneBatchIsSentOnceAndBigBatchesAreChunked) {
  const auto twice = build_archive_batch("a", "v", input_with(4, true));
  EXPECT_EQ(twice.back().params.size(), 4u * 23u);
  const auto big = build_archive_batch("a", "v", input_with(5000));
  std::size_t rows = 0, statements = 0;
  for (const auto& s : big)
    if (s.sql.starts_with("INSERT INTO points")) {
      EXPECT_LE(s.params.size(), 65535u);  // PostgreSQL's limit
      rows += s.params.size() / 23;
      ++statements;
    }
  EXPECT_EQ(rows, 5000u);
  EXPECT_GT(statements, 1u);
}

TEST(ArchiveBatch, RowsWhoseRecordIsGoneAreLeftOut) {
  auto in = input_with(2);
  in.scans.clear();
  const auto st = build_archive_batch("a", "v", in);
  ASSERT_EQ(st.size(), 1u);  // only the instrument: no scan to hang points on
}

TEST(ArchiveBatch, AnAlertCarriesItsResolution) {
  auto in = input_with(0);
  Alert a;
  a.id = 5;
  a.kind = "sustained_divergence";
  a.severity = Severity::critical;
  a.dedup_key = "sustained:scan:3";
  a.scan_id = 3;
  a.message = "scan 3: out_of_tolerance";
  a.first_at = a.last_at = "2026-01-01T00:00:02Z";
  a.resolved_at = "2026-01-01T00:00:09Z";
  a.resolution = "resolved: final verdict agrees: fine";
  in.alerts.emplace(5, a);
  in.rows.push_back({100, Kind::alert, 5, 0, "2026-01-01T00:00:09Z", nullptr, ""});
  const auto st = build_archive_batch("gcms-a", "1.2.3", in);
  const auto& ins = st.back();
  ASSERT_TRUE(ins.sql.starts_with("INSERT INTO alerts")) << ins.sql;
  ASSERT_EQ(ins.params.size(), 17u);
  EXPECT_EQ(ins.params[15], std::optional<std::string>("2026-01-01T00:00:09Z"));
  EXPECT_EQ(ins.params[16], std::optional<std::string>("resolved: final verdict agrees: fine"));
  // Upserted: a resolution reaches an alert the archive already holds.
  EXPECT_NE(ins.sql.find("resolved_at = excluded.resolved_at"), std::string::npos);
  EXPECT_NE(ins.sql.find("resolution = excluded.resolution"), std::string::npos);
  // A standing alert's resolution is NULL.
  in.alerts[5].resolved_at.reset();
  in.alerts[5].resolution.reset();
  const auto standing = build_archive_batch("gcms-a", "1.2.3", in);
  EXPECT_FALSE(standing.back().params[15].has_value());
  EXPECT_FALSE(standing.back().params[16].has_value());
}

TEST(ArchiveBatch, ArrayLiterals) {
  EXPECT_EQ(pg_float_array({}), "{}");
  EXPECT_EQ(pg_float_array({1.5, 2, 0.1, -3e-7}), "{1.5,2,0.1,-3e-07}");
  EXPECT_EQ(pg_text_array({"a", "b c", "q\"d", "s\\t"}), R"({"a","b c","q\"d","s\\t"})");
}

TEST(ArchiveSchema, VersionedMigrationsCreateTheDocumentedTablesAndViews) {
  ASSERT_EQ(archive_migrations().size(), static_cast<std::size_t>(kArchiveSchemaVersion));
  const auto& first = archive_migrations().front();
  for (const char* t : {"instruments", "samples", "scans", "scan_states", "points", "alerts"})
    EXPECT_NE(first.find(fmt::format("CREATE TABLE {} (", t)), std::string::npos) << t;
  for (const char* v : {"sample_points", "point_spectra", "scan_summary", "open_alerts"})
    EXPECT_NE(first.find(fmt::format("CREATE VIEW {} AS", v)), std::string::npos) << v;
  EXPECT_NE(first.find("PRIMARY KEY (instrument, scan_id, idx)"), std::string::npos);
  const auto& third = archive_migrations().at(2);
  EXPECT_NE(third.find("ADD COLUMN resolved_at"), std::string::npos);
  EXPECT_NE(third.find("ADD COLUMN resolution"), std::string::npos);
}

// ---- MQTT

TEST(MqttTopics, NamesAndRouting) {
  MqttTopics t{"lab/gonio", "gcms-a"};
  EXPECT_EQ(t.state(), "lab/gonio/gcms-a/state");
  EXPECT_EQ(t.scan(12), "lab/gonio/gcms-a/scan/12");
  EXPECT_EQ(t.progress(12), "lab/gonio/gcms-a/scan/12/progress");
  EXPECT_EQ(t.point(12), "lab/gonio/gcms-a/scan/12/point");
  EXPECT_EQ(t.alert(), "lab/gonio/gcms-a/alert");

  const auto state = mqtt_route(t, "instrument.state", R"({"state":"idle"})", std::nullopt);
  ASSERT_TRUE(state);
  EXPECT_EQ(state->topic, t.state());
  EXPECT_TRUE(state->retain);
  EXPECT_EQ(state->payload, R"({"state":"idle"})");  // the notification's params, unchanged

  const auto sc = mqtt_route(t, "scan.state", R"({"scan":12,"state":"running","reason":""})", std::nullopt);
  ASSERT_TRUE(sc);
  EXPECT_EQ(sc->topic, t.scan(12));
  EXPECT_TRUE(sc->retain);
  const auto pr = mqtt_route(t, "scan.progress", "{}", 12);
  ASSERT_TRUE(pr);
  EXPECT_EQ(pr->topic, t.progress(12));
  EXPECT_TRUE(pr->retain);
  const auto pt = mqtt_route(t, "scan.point", R"({"scan_id":12,"index":0})", std::nullopt);
  ASSERT_TRUE(pt);
  EXPECT_EQ(pt->topic, t.point(12));
  EXPECT_FALSE(pt->retain);
  const auto al = mqtt_route(t, "alert", R"({"id":1})", 12);
  ASSERT_TRUE(al);
  EXPECT_EQ(al->topic, t.alert());
  EXPECT_FALSE(al->retain);

  EXPECT_FALSE(mqtt_route(t, "something.else", "{}", std::nullopt));
  EXPECT_FALSE(mqtt_route(t, "scan.point", R"({"no":"scan"})", std::nullopt));
  EXPECT_EQ(json::parse(kMqttOffline)["state"], "offline");
}

// ---- configuration

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
