// The runner's one fault rule (docs/architecture.md §6), fault by fault on the mock: a point
// step that cannot finish pauses the scan and stores nothing of that point; a device's
// failure (the arms, the photometer, readings the reduction cannot use) raises a critical
// device_fault alert and latches the instrument, the store's raises a critical storage alert
// and latches nothing; after the resume every index is stored once. And instrument.home on
// the mock, whose arms both home to 0° where they would touch: the incidence arm homes, then
// stands clear while the receive arm homes.
#include <sqlite3.h>

#include <gtest/gtest.h>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

const json kPlan{{"grids", {"in=45;out=-30:30:10"}}, {"reference", "every_point"}};  // 7 points

json all_points(Conn& c, std::int64_t scan) {
  return c.call("scan.points", json{{"scan", scan}, {"offset", 0}, {"limit", 1000}})["points"];
}

void expect_each_index_once(const json& points, std::size_t total) {
  ASSERT_EQ(points.size(), total);
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_EQ(points[i]["index"], i);
}

std::vector<json> alerts_of(Conn& c, std::int64_t scan, const std::string& kind) {
  std::vector<json> out;
  for (const auto& a : c.call("alert.list", json{{"scan", scan}}))
    if (a["kind"] == kind) out.push_back(a);
  return out;
}

// What a device fault leaves: the scan paused with the points before it, one critical
// device_fault alert, the instrument latched; then a resume finishes the scan.
void expect_device_fault(const std::string& fault, const std::string& reason_has,
                         std::optional<int> points_before) {
  SCOPED_TRACE(fault);
  TempDir dir;
  MockOptions o;
  o.faults = fault;
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  const auto id = submit(c, "tile", kTrueSample, kPlan);
  const auto sc = wait_state(c, id, {"paused", "completed", "failed"});
  ASSERT_EQ(sc["state"], "paused") << g.log_text();
  EXPECT_NE(sc["reason"].get<std::string>().find("device fault"), std::string::npos) << sc["reason"];
  EXPECT_NE(sc["reason"].get<std::string>().find(reason_has), std::string::npos) << sc["reason"];
  if (points_before) {
    EXPECT_EQ(sc["points_done"], *points_before);
  }
  expect_each_index_once(all_points(c, id), sc["points_done"].get<std::size_t>());
  const auto faults = alerts_of(c, id, "device_fault");
  ASSERT_EQ(faults.size(), 1u);
  EXPECT_EQ(faults[0]["severity"], "critical");
  EXPECT_TRUE(alerts_of(c, id, "storage").empty());
  const auto st = c.call("instrument.status");
  EXPECT_TRUE(st["fault_latched"].get<bool>());
  EXPECT_EQ(st["state"], "fault");
  c.call("scan.resume", json{{"scan", id}});
  EXPECT_EQ(wait_state(c, id, {"completed", "paused", "failed"})["state"], "completed") << g.log_text();
  expect_each_index_once(all_points(c, id), 7);
  EXPECT_FALSE(c.call("instrument.status")["fault_latched"].get<bool>());
}

TEST(PointFault, TheArmsFailingToMoveAreADeviceFault) {  // step 3, motion controller
  expect_device_fault("stall_at_move = 4", "stalled", std::nullopt);
}

TEST(PointFault, ThePhotometerNotAnsweringIsADeviceFault) {  // step 3, photometer
  expect_device_fault("timeout_at_point = 3, timeout_wait_ms = 50", "no reply", 2);
}

TEST(PointFault, ReadingsTheReductionCannotUseAreThePhotometersDeviceFault) {  // step 4
  expect_device_fault("dark_reference_at_point = 3", "not above dark", 2);
}

// Step 6: the store refuses point 2 (a trigger stands in for any failure of the store that is
// not a point already stored). The scan pauses with a storage alert, the instrument is not
// latched, and once the store takes points again the resume stores every index once.
TEST(PointFault, TheStoreRefusingThePointIsAStorageFaultAndNoLatch) {
  TempDir dir;
  Goniod g(dir.path, mock_config(MockOptions{}));
  auto c = g.unix_conn();
  const auto db_path = dir.path / "goniod.db";
  ASSERT_TRUE(fs::exists(db_path));
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(db_path.c_str(), &db), SQLITE_OK);
  const auto exec = [&](const char* sql) {
    sqlite3_busy_timeout(db, 5000);
    char* err = nullptr;
    const int rc = sqlite3_exec(db, sql, nullptr, nullptr, &err);
    EXPECT_EQ(rc, SQLITE_OK) << (err ? err : "");
    sqlite3_free(err);
  };
  exec("CREATE TRIGGER refuse_point BEFORE INSERT ON points WHEN NEW.idx = 2 "
       "BEGIN SELECT RAISE(ABORT, 'the disk controller refused the write'); END");
  const auto id = submit(c, "tile", kTrueSample, kPlan);
  const auto sc = wait_state(c, id, {"paused", "completed", "failed"});
  ASSERT_EQ(sc["state"], "paused") << g.log_text();
  EXPECT_EQ(sc["reason"].get<std::string>().rfind("storage: ", 0), 0u) << sc["reason"];
  EXPECT_EQ(sc["points_done"], 2);
  expect_each_index_once(all_points(c, id), 2);
  const auto storage = alerts_of(c, id, "storage");
  ASSERT_EQ(storage.size(), 1u);
  EXPECT_EQ(storage[0]["severity"], "critical");
  EXPECT_TRUE(alerts_of(c, id, "device_fault").empty());
  const auto st = c.call("instrument.status");
  EXPECT_FALSE(st["fault_latched"].get<bool>());
  EXPECT_NE(st["state"], "fault");
  exec("DROP TRIGGER refuse_point");
  sqlite3_close(db);
  c.call("scan.resume", json{{"scan", id}});
  EXPECT_EQ(wait_state(c, id, {"completed", "paused", "failed"})["state"], "completed") << g.log_text();
  expect_each_index_once(all_points(c, id), 7);
}

// The mock homes both arms to 0°, inside their clearance: homing moves the homed incidence
// arm one degree beyond the minimum separation before the receive arm homes, and a scan
// runs from there.
TEST(Homing, BothArmsHomeOnTheMockAndTheIncidenceArmStandsClear) {
  TempDir dir;
  Goniod g(dir.path, mock_config(MockOptions{}));
  auto c = g.unix_conn();
  const auto r = c.request("instrument.home");
  ASSERT_FALSE(r.contains("error")) << r.dump();
  const auto& st = r["result"];
  const double min = st["limits"]["min_separation"].get<double>();
  ASSERT_GT(min, 0);
  EXPECT_DOUBLE_EQ(st["positions"]["receive"].get<double>(), 0);
  EXPECT_DOUBLE_EQ(st["positions"]["incidence"].get<double>(), min + 1);
  EXPECT_EQ(st["state"], "idle");
  const auto id = submit(c, "tile", kTrueSample, kPlan);
  EXPECT_EQ(wait_state(c, id, {"completed", "paused", "failed"})["state"], "completed") << g.log_text();
}

}  // namespace
}  // namespace gonio::test
