// Retention: only points the central archive committed are pruned, the scans' summaries and
// verdicts stay, the space goes back to the file system; schema 7 makes an existing file
// incremental-vacuum.
#include <sqlite3.h>
#include <unistd.h>

#include <filesystem>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "gonio/daemon/store/retention.hpp"
#include "gonio/daemon/store/store.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kLater = "9999-01-01T00:00:00Z";  // every finished scan is older than this

class RetentionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / fmt::format("gonio-retention-test-{}-{}", ::getpid(),
                                                    ::testing::UnitTest::GetInstance()->random_seed());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    file_ = dir_ / "goniod.db";
  }
  void TearDown() override { fs::remove_all(dir_); }

  static SampleSpec tile() {
    SampleSpec spec;
    spec.name = "tile";
    return spec;
  }
  // A scan of `n` points, measured and finished (`final_state`), with a verdict.
  static std::int64_t measured_scan(Store& s, std::int64_t sample, std::size_t n,
                                    ScanState final_state = ScanState::completed) {
    ScanPlan p;
    p.sample_id = sample;
    for (std::size_t i = 0; i < n; ++i) p.geometries.push_back(Geometry::in_plane(45, 0.1 * static_cast<double>(i)));
    const auto sc = s.insert_scan(p, false, "test");
    s.set_scan_state(sc.id, ScanState::running, "", "test");
    // 31 channels, as a visible scan has: points of a few kB, as in the field.
    std::vector<double> wl, v, u;
    for (int c = 0; c < 31; ++c) wl.push_back(400 + 10 * c), v.push_back(0.01 * c), u.push_back(0.001);
    for (std::size_t i = 0; i < n; ++i) {
      PointRecord r;
      r.scan_id = sc.id;
      r.index = static_cast<std::int64_t>(i);
      r.geometry_index = r.index;
      r.planned = r.actual = Geometry::in_plane(45, 0.1 * static_cast<double>(i));
      r.started_at = r.finished_at = utc::now();
      r.measured = Spectrum(WavelengthGrid(wl), v, u);
      s.insert_point(r);
    }
    if (final_state != ScanState::running) s.set_scan_state(sc.id, final_state, "", "test");
    s.insert_fit(sc.id, FitKind::verdict, "", json{{"consistent", true}}, "goniod");
    return sc.id;
  }
  // What the archive shipper does once PostgreSQL has committed: the outbox rows up to and
  // including the last one of scan `id` leave.
  static void ship_through(Store& s, std::int64_t id) {
    const auto rows = s.outbox_batch(100000);
    std::int64_t last = 0;
    for (const auto& r : rows)
      if (r.kind != OutboxRow::Kind::alert && r.ref == id && r.kind != OutboxRow::Kind::sample) last = r.seq;
    ASSERT_GT(last, 0);
    s.outbox_remove(rows.front().seq, last);
  }
  std::int64_t pragma(const std::string& name) const {
    sqlite3* db = nullptr;
    sqlite3_open_v2(file_.c_str(), &db, SQLITE_OPEN_READONLY, nullptr);
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(db, ("PRAGMA " + name).c_str(), -1, &st, nullptr);
    std::int64_t v = -1;
    if (sqlite3_step(st) == SQLITE_ROW) v = sqlite3_column_int64(st, 0);
    sqlite3_finalize(st);
    sqlite3_close(db);
    return v;
  }

  fs::path dir_, file_;
};

TEST_F(RetentionTest, PrunesOnlyFinishedScansTheArchiveCommittedKeepingSummariesAndReturningSpace) {
  Store s(file_);
  s.set_outbox(true);
  const auto sample = s.create_sample(tile(), "test").id;
  const auto shipped = measured_scan(s, sample, 400);
  const auto waiting = measured_scan(s, sample, 40);                      // still in the outbox
  const auto running = measured_scan(s, sample, 10, ScanState::running);  // not finished
  ship_through(s, shipped);
  const auto pages = pragma("page_count");

  // Not older than the retention yet: nothing.
  EXPECT_EQ(s.prune_archived("2000-01-01T00:00:00Z").scans, 0);
  const auto r = s.prune_archived(kLater);
  EXPECT_EQ(r.scans, 1);
  EXPECT_EQ(r.points, 400);
  EXPECT_GT(r.pages_freed, 0);
  EXPECT_EQ(pragma("freelist_count"), 0);
  EXPECT_LT(pragma("page_count"), pages - r.pages_freed / 2);

  EXPECT_EQ(s.point_count(shipped), 0u);
  EXPECT_TRUE(s.points_pruned_at(shipped));
  const auto kept = s.scan(shipped);
  ASSERT_TRUE(kept);
  EXPECT_EQ(kept->points_done, 400u);  // the summary stays
  EXPECT_EQ(kept->state, ScanState::completed);
  EXPECT_TRUE(s.latest_fit(shipped, FitKind::verdict));
  EXPECT_EQ(s.point_count(waiting), 40u);
  EXPECT_FALSE(s.points_pruned_at(waiting));
  EXPECT_EQ(s.point_count(running), 10u);

  // Once the archive has the second one too, it goes; pruning again finds nothing new.
  ship_through(s, waiting);
  EXPECT_EQ(s.prune_archived(kLater).scans, 1);
  EXPECT_EQ(s.prune_archived(kLater).scans, 0);
  EXPECT_EQ(s.point_count(running), 10u);
}

TEST_F(RetentionTest, NothingShippedNothingPruned) {
  Store s(file_);  // no archive: the outbox is off
  const auto sample = s.create_sample(tile(), "test").id;
  const auto id = measured_scan(s, sample, 20);
  EXPECT_EQ(s.prune_archived(kLater).scans, 0);
  EXPECT_EQ(s.point_count(id), 20u);
  // The keeper without an archive does nothing at all, whatever the retention.
  RetentionKeeper keeper(s, 0.000001, false);
  EXPECT_EQ(keeper.run_once().scans, 0);
  EXPECT_EQ(s.point_count(id), 20u);
}

TEST_F(RetentionTest, AScanQueuedAgainForTheArchiveWaitsUntilItIsShippedAgain) {
  Store s(file_);
  s.set_outbox(true);
  const auto sample = s.create_sample(tile(), "test").id;
  const auto id = measured_scan(s, sample, 20);
  ship_through(s, id);
  s.outbox_reship(id, "test");
  EXPECT_EQ(s.prune_archived(kLater).scans, 0);
  ship_through(s, id);
  EXPECT_EQ(s.prune_archived(kLater).scans, 1);
}

TEST_F(RetentionTest, PointsMeasuredBeforeTheArchiveWasConfiguredAreNeverPruned) {
  Store s(file_);
  const auto sample = s.create_sample(tile(), "test").id;
  const auto id = measured_scan(s, sample, 20);
  s.set_outbox(true);  // the archive comes later: the old scan was never shipped
  const auto later = measured_scan(s, sample, 5);
  ship_through(s, later);
  EXPECT_EQ(s.prune_archived(kLater).scans, 1);
  EXPECT_EQ(s.point_count(id), 20u);
  EXPECT_EQ(s.point_count(later), 0u);
}

TEST_F(RetentionTest, SchemaSevenMakesAnExistingStoreIncrementalVacuum) {
  Store::create_at_version(file_, 6);
  EXPECT_EQ(pragma("auto_vacuum"), 0);
  {
    Store s(file_);
    EXPECT_EQ(s.schema_version(), 7);
  }
  EXPECT_EQ(pragma("auto_vacuum"), 2);
  fs::remove(file_);
  Store fresh(file_);
  EXPECT_EQ(pragma("auto_vacuum"), 2);
}

}  // namespace
}  // namespace gonio::daemon
