// Store: migrations, catalog, queue order, points without duplicates, alerts dedup, audit.
#include <sqlite3.h>
#include <unistd.h>

#include <filesystem>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "gonio/daemon/store/store.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {
namespace {

namespace fs = std::filesystem;

class StoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / fmt::format("gonio-store-test-{}-{}", ::getpid(),
                                                    ::testing::UnitTest::GetInstance()->random_seed());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    file_ = dir_ / "goniod.db";
  }
  void TearDown() override { fs::remove_all(dir_); }

  static ScanPlan plan(std::int64_t sample, int priority = 0, std::size_t n = 3) {
    ScanPlan p;
    p.sample_id = sample;
    for (std::size_t i = 0; i < n; ++i) p.geometries.push_back(Geometry::in_plane(45, 10.0 * static_cast<double>(i)));
    p.priority = priority;
    return p;
  }
  static PointRecord point(std::int64_t scan, std::int64_t index, bool diverged = false) {
    PointRecord p;
    p.scan_id = scan;
    p.index = index;
    p.geometry_index = index;
    p.planned = p.actual = Geometry::in_plane(45, 0);
    p.started_at = p.finished_at = utc::now();
    p.measured = Spectrum(WavelengthGrid::parse("500,600"), {0.1 * static_cast<double>(index), 0.2}, {0.01, 0.01});
    p.diverged = diverged;
    return p;
  }

  fs::path dir_, file_;
};

TEST_F(StoreTest, MigratesToTheCurrentSchemaAndRefusesNewerFiles) {
  {
    Store s(file_);
    EXPECT_EQ(s.schema_version(), Store::kSchemaVersion);
    EXPECT_EQ(s.audit_events(0, 100).size(), static_cast<std::size_t>(Store::kSchemaVersion));  // one per migration
  }
  {
    Store again(file_);  // idempotent
    EXPECT_EQ(again.audit_events(0, 100).size(), static_cast<std::size_t>(Store::kSchemaVersion));
  }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file_.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "PRAGMA user_version = 99", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  try {
    Store newer(file_);
    FAIL() << "a newer schema was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::unsupported);
    EXPECT_NE(std::string(e.what()).find("99"), std::string::npos);
  }
}

TEST_F(StoreTest, MigratesAVersion2StoreKeepingItsRowsAndAddingFitsAndProfiles) {
  // A store as goniod 0.1 (schema 2) left it: one sample and one alert written by hand.
  Store::create_at_version(file_, 2);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file_.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db,
                         "INSERT INTO samples(name, notes, bsdf, tolerance, created_at) VALUES "
                         "('white', '', 'lambert:albedo=0.9', 0.02, '2026-01-01T00:00:00Z');"
                         "INSERT INTO alerts(kind, severity, dedup_key, message, first_at, last_at) "
                         "VALUES ('device_fault', 2, 'k', 'old', '2026-01-01T00:00:00Z', "
                         "'2026-01-01T00:00:00Z');",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);

  Store s(file_);
  EXPECT_EQ(s.schema_version(), Store::kSchemaVersion);
  const auto white = s.sample_by_name("white");
  ASSERT_TRUE(white.has_value());
  EXPECT_EQ(white->spec.bsdf, "lambert:albedo=0.9");
  ASSERT_TRUE(s.alert(1).has_value());
  EXPECT_EQ(s.alert(1)->message, "old");
  // The new tables work: a first profile is version 1.
  EXPECT_FALSE(s.latest_profile().has_value());
  const auto p = s.insert_profile("gcms4", nlohmann::json{{"name", "gcms4"}}, std::nullopt, std::nullopt, "test");
  EXPECT_EQ(p.version, 1);
  EXPECT_EQ(s.latest_profile()->version, 1);
  EXPECT_EQ(s.insert_profile("gcms4", nlohmann::json{{"name", "gcms4"}}, std::nullopt, std::nullopt, "test").version, 2);
  EXPECT_THROW(Store::create_at_version(dir_ / "x.db", Store::kSchemaVersion + 1), Error);
}

TEST_F(StoreTest, UsesWalMode) {
  Store s(file_);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file_.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  sqlite3_prepare_v2(db, "PRAGMA journal_mode", -1, &st, nullptr);
  ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(st, 0)), "wal");
  sqlite3_finalize(st);
  sqlite3_close(db);
}

TEST_F(StoreTest, MigratesAVersion4StoreAddingTheCatalogueColumns) {
  Store::create_at_version(file_, 4);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file_.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db,
                         "INSERT INTO samples(name, notes, bsdf, tolerance, created_at) VALUES "
                         "('white', '', 'lambert:albedo=0.9', 0.02, '2026-01-01T00:00:00Z');",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  Store s(file_);
  const auto white = s.sample_by_name("white");
  ASSERT_TRUE(white.has_value());
  EXPECT_EQ(white->spec.model_u, 0);  // as a formula was judged before: no catalogue u
  EXPECT_EQ(white->catalogue, "");
  SampleSpec spec;
  spec.name = "tile";
  spec.bsdf = "@masters/tile.ssdd";
  spec.model_u = 0.03;
  const auto t = s.create_sample(spec, "test", R"({"route":"master","points":[]})");
  EXPECT_EQ(s.sample(t.id)->spec.model_u, 0.03);
  EXPECT_EQ(s.sample(t.id)->catalogue, R"({"route":"master","points":[]})");
  const auto j = nlohmann::json(*s.sample(t.id));
  EXPECT_EQ(j["route"], "master");
  EXPECT_FALSE(j["catalogue"].contains("points"));  // the data stay in the store
  EXPECT_EQ(nlohmann::json(*white)["route"], "formula");
}

TEST_F(StoreTest, SamplesAreUniqueByName) {
  Store s(file_);
  SampleSpec spec;
  spec.name = "tile";
  spec.bsdf = "lambert:albedo=0.5";
  const auto a = s.create_sample(spec, "alice");
  EXPECT_GT(a.id, 0);
  EXPECT_EQ(s.sample_by_name("tile")->id, a.id);
  EXPECT_EQ(s.sample(a.id)->spec, spec);
  try {
    s.create_sample(spec, "bob");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::invalid_state);
    EXPECT_EQ(e.field(), "name");
  }
  EXPECT_EQ(s.samples().size(), 1u);
  EXPECT_EQ(s.audit_events(0, 1).front().action, "sample.create");
  EXPECT_EQ(s.audit_events(0, 1).front().actor, "alice");
}

TEST_F(StoreTest, QueueOrderFollowsPriorityThenSubmissionAndReorder) {
  Store s(file_);
  SampleSpec spec;
  spec.name = "x";
  const auto sid = s.create_sample(spec, "t").id;
  const auto a = s.insert_scan(plan(sid, 0), true, "t").id;
  const auto b = s.insert_scan(plan(sid, 0), true, "t").id;
  const auto c = s.insert_scan(plan(sid, 5), true, "t").id;   // jumps ahead of a and b
  const auto d = s.insert_scan(plan(sid, -1), true, "t").id;  // last
  const auto order = [&] {
    std::vector<std::int64_t> ids;
    for (const auto& x : s.queue()) ids.push_back(x.id);
    return ids;
  };
  EXPECT_EQ(order(), (std::vector<std::int64_t>{c, a, b, d}));
  s.reorder(d, 0, "t");
  EXPECT_EQ(order(), (std::vector<std::int64_t>{d, c, a, b}));
  EXPECT_EQ(s.next_runnable(utc::now())->id, d);
  s.set_scan_state(d, ScanState::paused, "held", "t");
  EXPECT_EQ(s.next_runnable(utc::now())->id, c);  // paused scans are skipped
  s.set_scan_state(b, ScanState::interrupted, "crash", "t");
  EXPECT_EQ(s.next_runnable(utc::now())->id, b);  // interrupted scans go first
  s.set_scan_state(b, ScanState::cancelled, "no", "t");
  EXPECT_TRUE(s.scan(b)->finished_at.has_value());
  try {
    s.reorder(b, 0, "t");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::invalid_state);
  }
}

TEST_F(StoreTest, ScansAreListedNewestFirstByStateSampleTimeAndLabel) {
  Store s(file_);
  SampleSpec spec;
  spec.name = "x";
  const auto x = s.create_sample(spec, "t").id;
  spec.name = "y";
  const auto y = s.create_sample(spec, "t").id;
  auto named = [](ScanPlan p, std::string name) {
    p.name = std::move(name);
    return p;
  };
  const auto a = s.insert_scan(named(plan(x), "Gloss A"), true, "t");
  const auto b = s.insert_scan(named(plan(y), "matte"), true, "t");
  const auto c = s.insert_scan(named(plan(x), ""), true, "t");
  s.set_scan_state(b.id, ScanState::cancelled, "no", "t");
  const auto ids = [&](ScanFilter f) {
    std::vector<std::int64_t> out;
    for (const auto& sc : s.scans(f)) out.push_back(sc.id);
    return out;
  };
  using V = std::vector<std::int64_t>;
  EXPECT_EQ(ids({}), (V{c.id, b.id, a.id}));
  ScanFilter f;
  f.text = "GLOSS";
  EXPECT_EQ(ids(f), (V{a.id}));
  f.text = "t";  // "matte"; the unnamed scan has no label to match
  EXPECT_EQ(ids(f), (V{b.id}));
  f.text = "%";  // a character, not a pattern
  EXPECT_EQ(ids(f), V{});
  f = {};
  f.sample_id = x;
  EXPECT_EQ(ids(f), (V{c.id, a.id}));
  f.state = ScanState::queued;
  f.limit = 1;
  EXPECT_EQ(ids(f), (V{c.id}));
  f.offset = 1;
  EXPECT_EQ(ids(f), (V{a.id}));
  // Submission times: [since, until).
  f = {};
  f.since = a.submitted_at;
  EXPECT_EQ(ids(f), (V{c.id, b.id, a.id}));
  f.until = a.submitted_at;
  EXPECT_EQ(ids(f), V{});
  f.since = "2000-01-01T00:00:00.000Z";
  f.until = "2000-01-02T00:00:00.000Z";
  EXPECT_EQ(ids(f), V{});
  f.until = "2999-01-01T00:00:00.000Z";
  EXPECT_EQ(ids(f).size(), 3u);
}

TEST_F(StoreTest, NotBeforeHoldsAScanBack) {
  Store s(file_);
  SampleSpec spec;
  spec.name = "x";
  const auto sid = s.create_sample(spec, "t").id;
  auto p = plan(sid);
  p.not_before = "2031-06-01T00:00:00.000Z";
  const auto id = s.insert_scan(p, true, "t").id;
  std::optional<std::string> earliest;
  EXPECT_FALSE(s.next_runnable("2031-05-31T23:59:59.000Z", &earliest).has_value());
  EXPECT_EQ(earliest.value(), "2031-06-01T00:00:00.000Z");
  EXPECT_EQ(s.next_runnable("2031-06-01T00:00:00.000Z")->id, id);
}

TEST_F(StoreTest, PointsAreStoredOnceAndSurviveReopening) {
  std::int64_t id = 0;
  {
    Store s(file_);
    SampleSpec spec;
    spec.name = "x";
    id = s.insert_scan(plan(s.create_sample(spec, "t").id), true, "t").id;
    s.set_scan_state(id, ScanState::running, "", "goniod");
    EXPECT_EQ(s.next_point_index(id), 0);
    s.insert_point(point(id, 0));
    s.insert_point(point(id, 1, true));
    try {
      s.insert_point(point(id, 1));
      FAIL() << "a point was stored twice";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), Errc::invalid_state);
    }
    EXPECT_EQ(s.next_point_index(id), 2);
    const auto sc = s.scan(id);
    EXPECT_EQ(sc->points_done, 2u);
    EXPECT_EQ(sc->points_diverged, 1u);
  }
  Store s(file_);
  EXPECT_EQ(s.recover_running("crash"), (std::vector<std::int64_t>{id}));
  EXPECT_EQ(s.scan(id)->state, ScanState::interrupted);
  const auto pts = s.points(id, 0, 10);
  ASSERT_EQ(pts.size(), 2u);
  EXPECT_EQ(pts[1].measured, point(id, 1, true).measured);
  EXPECT_TRUE(pts[1].diverged);
  EXPECT_EQ(pts[0].index, 0);
  EXPECT_EQ(s.points(id, 1, 10).size(), 1u);  // offset is the point index
  EXPECT_EQ(s.point_count(id), 2u);
}

TEST_F(StoreTest, AlertsDeduplicateUntilAcknowledged) {
  Store s(file_);
  AlertDraft d;
  d.kind = "divergence";
  d.severity = Severity::warning;
  d.dedup_key = "divergence:scan:1";
  d.scan_id = 1;
  d.message = "first";
  bool created = false;
  const auto a = s.raise_alert(d, &created);
  EXPECT_TRUE(created);
  d.message = "second";
  d.severity = Severity::info;  // never lowers
  const auto b = s.raise_alert(d, &created);
  EXPECT_FALSE(created);
  EXPECT_EQ(b.id, a.id);
  EXPECT_EQ(b.count, 2);
  EXPECT_EQ(b.severity, Severity::warning);
  EXPECT_EQ(b.message, "second");
  const auto acked = s.ack_alert(a.id, "tech");
  EXPECT_TRUE(acked.acknowledged);
  EXPECT_EQ(acked.acknowledged_by, "tech");
  const auto c = s.raise_alert(d, &created);
  EXPECT_TRUE(created);
  EXPECT_NE(c.id, a.id);
  AlertFilter open;
  open.acknowledged = false;
  EXPECT_EQ(s.alerts(open).size(), 1u);
  AlertFilter critical;
  critical.min_severity = Severity::critical;
  EXPECT_TRUE(s.alerts(critical).empty());
  try {
    s.ack_alert(999, "tech");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::not_found);
  }
}

TEST_F(StoreTest, TokensKeepOnlyHashes) {
  Store s(file_);
  s.put_token(TokenEntry{"robot", Role::technician, std::string(64, 'a')});
  ASSERT_EQ(s.tokens().size(), 1u);
  EXPECT_EQ(s.tokens()[0].role, Role::technician);
  EXPECT_TRUE(s.delete_token("robot"));
  EXPECT_FALSE(s.delete_token("robot"));
}

}  // namespace
}  // namespace gonio::daemon
