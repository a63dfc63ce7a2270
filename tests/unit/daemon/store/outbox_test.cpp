// The store's outbox (daemon/src/store/outbox.cpp): written with what it mirrors, in commit
// order, only while an archive is configured; reship queues a scan again.
#include <unistd.h>

#include <filesystem>

#include <fmt/format.h>
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace gonio::daemon
