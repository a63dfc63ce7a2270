// The archive batch (daemon/src/fleet/archive_batch.cpp): upserts, parents first, each record
// once, points in order, chunked; PostgreSQL array literals.
#include <gtest/gtest.h>

#include "gonio/daemon/fleet/archive.hpp"
#include "gonio/daemon/store/store.hpp"
#include "gonio/proto/point.hpp"

namespace gonio::daemon {
namespace {

using nlohmann::json;
using Kind = OutboxRow::Kind;

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

}  // namespace
}  // namespace gonio::daemon
