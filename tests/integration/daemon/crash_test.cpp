// Crash safety and faults: SIGKILL mid-scan, SIGTERM mid-scan, a device fault mid-scan.
// After each, the scan resumes at the next unmeasured point: nothing lost, nothing twice.
#include <gtest/gtest.h>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

json all_points(Conn& c, std::int64_t scan) {
  return c.call("scan.points", json{{"scan", scan}, {"offset", 0}, {"limit", 1000}})["points"];
}

void expect_each_index_once(const json& points, std::size_t total) {
  ASSERT_EQ(points.size(), total);
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_EQ(points[i]["index"], i);
}

TEST(Crash, SigkillMidScanThenRestartResumesWithNothingLostOrDuplicated) {
  TempDir dir;
  MockOptions o;
  o.time_scale = 0.1;  // about 40 ms of motion and integration per point
  const auto cfg = mock_config(o);
  std::int64_t id = 0;
  json before;
  {
    Goniod g(dir.path, cfg);
    auto c = g.unix_conn();
    id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:2"}}});  // 31 points
    ASSERT_TRUE(eventually([&] { return c.call("scan.get", json{{"scan", id}})["points_done"].get<int>() >= 6; }))
        << g.log_text();
    EXPECT_EQ(g.stop(SIGKILL), 128 + SIGKILL);
  }
  {
    // The points committed before the kill, read from the store by a fresh goniod; the scan
    // resumes at once, so take them in the same breath as the restart.
    Goniod g(dir.path, cfg);
    auto c = g.unix_conn();
    before = all_points(c, id);
    ASSERT_GE(before.size(), 6u);
    const auto sc = wait_state(c, id, {"completed", "paused", "failed"}, 30s);
    ASSERT_EQ(sc["state"], "completed") << sc.dump() << g.log_text();
    const auto after = all_points(c, id);
    expect_each_index_once(after, 31);
    // Committed points are unchanged by the restart.
    for (std::size_t i = 0; i < std::min<std::size_t>(6, before.size()); ++i) EXPECT_EQ(after[i], before[i]);
    // The audit log says what happened.
    bool interrupted = false;
    for (const auto& e : c.call("system.audit", json{{"limit", 1000}}))
      if (e["action"] == "scan.state" && e["detail"]["to"] == "interrupted") interrupted = true;
    EXPECT_TRUE(interrupted);
    EXPECT_EQ(g.stop(), 0);
  }
}

TEST(Crash, SigtermParksTheScanAndRestartFinishesIt) {
  TempDir dir;
  MockOptions o;
  o.time_scale = 0.1;
  const auto cfg = mock_config(o);
  std::int64_t id = 0;
  {
    Goniod g(dir.path, cfg);
    auto c = g.unix_conn();
    id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:2"}}});
    ASSERT_TRUE(eventually([&] { return c.call("scan.get", json{{"scan", id}})["points_done"].get<int>() >= 3; }));
    EXPECT_EQ(g.stop(SIGTERM), 0) << g.log_text();
    EXPECT_NE(g.log_text().find("stopped cleanly"), std::string::npos);
  }
  {
    Goniod g(dir.path, cfg);
    auto c = g.unix_conn();
    const auto sc = wait_state(c, id, {"completed", "paused", "failed"}, 30s);
    ASSERT_EQ(sc["state"], "completed") << sc.dump();
    expect_each_index_once(all_points(c, id), 31);
    EXPECT_EQ(g.stop(), 0);
  }
}

TEST(Crash, DeviceFaultPausesLatchesAlertsAndResumes) {
  TempDir dir;
  MockOptions o;
  o.faults = "garbage_at_point = 4";  // the 4th sample reading is unreadable
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  const auto id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:5"}}});  // 13 points
  const auto sc = wait_state(c, id, {"paused", "completed", "failed"});
  ASSERT_EQ(sc["state"], "paused") << sc.dump();
  EXPECT_NE(sc["reason"].get<std::string>().find("protocol_error"), std::string::npos) << sc["reason"];
  EXPECT_EQ(sc["points_done"], 3);
  const auto st = c.call("instrument.status");
  EXPECT_EQ(st["state"], "fault");
  EXPECT_TRUE(st["fault_latched"].get<bool>());
  const auto alerts = c.call("alert.list", json{{"scan", id}, {"severity", "critical"}});
  ASSERT_EQ(alerts.size(), 1u);
  EXPECT_EQ(alerts[0]["kind"], "device_fault");
  // Nothing else starts while the fault is latched.
  const auto other = c.call("scan.submit", json{{"sample", "tile"}, {"geometries", {"45as15"}}})["id"].get<std::int64_t>();
  std::this_thread::sleep_for(1s);
  EXPECT_EQ(c.call("scan.get", json{{"scan", other}})["state"], "queued");
  // A technician resumes: the scan continues at point 3 and completes, then the other runs.
  c.call("scan.resume", json{{"scan", id}});
  EXPECT_EQ(wait_state(c, id, {"completed", "paused"})["state"], "completed");
  expect_each_index_once(all_points(c, id), 13);
  EXPECT_EQ(wait_state(c, other, {"completed"})["state"], "completed");
  c.call("alert.ack", json{{"alert", alerts[0]["id"]}});
  EXPECT_TRUE(c.call("alert.list", json{{"acknowledged", false}, {"severity", "critical"}}).empty());
}

TEST(Crash, InstrumentStopPausesTheRunningScanAtOnce) {
  TempDir dir;
  MockOptions o;
  o.time_scale = 0.2;
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  const auto id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:2"}}});
  ASSERT_EQ(wait_state(c, id, {"running"})["state"], "running");
  auto tech = g.unix_conn();
  const auto r = tech.call("instrument.stop");
  EXPECT_EQ(r["scan"], id);
  const auto sc = wait_state(c, id, {"paused"});
  EXPECT_EQ(sc["state"], "paused");
  EXPECT_NE(sc["reason"].get<std::string>().find("stopped by"), std::string::npos);
  // Manual commands work again once nothing runs.
  EXPECT_FALSE(c.request("instrument.move", json{{"incidence", 30}}).contains("error"));
  EXPECT_NEAR(c.call("instrument.status")["positions"]["incidence"].get<double>(), 30, 1e-6);
  c.call("scan.resume", json{{"scan", id}});
  ASSERT_EQ(wait_state(c, id, {"completed"}, 30s)["state"], "completed");
  expect_each_index_once(all_points(c, id), 31);
}

}  // namespace
}  // namespace gonio::test
