// Devices that come back: a photometer unplugged mid-scan (the mock's disconnect_at_point)
// is dropped and reopened with back-off while the scan waits paused, and a technician's
// resume (or auto-resume) then finishes the scan; a SCPI photometer on TCP whose device
// (a gonio-devsim process) reboots on the same port is reconnected the same way.
#include <csignal>
#include <cstdio>

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "gonio/test/daemon_harness.hpp"

extern char** environ;

namespace gonio::test {
namespace {

json all_points(Conn& c, std::int64_t scan) {
  return c.call("scan.points", json{{"scan", scan}, {"offset", 0}, {"limit", 1000}})["points"];
}

void expect_each_index_once(const json& points, std::size_t total) {
  ASSERT_EQ(points.size(), total);
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_EQ(points[i]["index"], i);
}

json photometer_link(Conn& c) { return c.call("instrument.status")["devices"]["photometer"]; }

std::string fast_reconnect(const std::string& more = "") {
  return "[instrument]\nreconnect_initial_s = 0.05\nreconnect_max_s = 0.2\n" + more;
}

TEST(Reconnect, UnpluggedPhotometerComesBackAndResumeFinishesTheScan) {
  TempDir dir;
  MockOptions o;
  o.faults = "disconnect_at_point = 4";  // unplugged at the 4th sample reading, back at once
  o.extra = fast_reconnect();
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  const auto id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:5"}}});  // 13 points
  const auto sc = wait_state(c, id, {"paused", "completed", "failed"});
  ASSERT_EQ(sc["state"], "paused") << sc.dump();
  EXPECT_NE(sc["reason"].get<std::string>().find("disconnected"), std::string::npos) << sc["reason"];
  EXPECT_EQ(sc["points_done"], 3);
  // The photometer is reopened by itself; the fault stays latched for the technician.
  ASSERT_TRUE(eventually([&] { return photometer_link(c)["reconnects"] == 1; })) << g.log_text();
  const auto st = c.call("instrument.status");
  EXPECT_EQ(st["devices"]["photometer"]["link"], "up");
  EXPECT_EQ(st["devices"]["photometer"]["last_errc"], "disconnected");
  EXPECT_EQ(st["devices"]["motion"]["link"], "up");
  EXPECT_EQ(st["devices"]["motion"]["reconnects"], 0);
  EXPECT_TRUE(st["axes_to_home"].empty());  // the arms never lost their link
  EXPECT_TRUE(st["fault_latched"].get<bool>());
  EXPECT_EQ(st["state"], "fault");
  c.call("scan.resume", json{{"scan", id}});
  EXPECT_EQ(wait_state(c, id, {"completed", "paused", "failed"})["state"], "completed");
  expect_each_index_once(all_points(c, id), 13);
}

TEST(Reconnect, PhotometerStillUnpluggedIsRetriedWithCappedBackOffAndTheScanWaits) {
  TempDir dir;
  MockOptions o;
  o.faults = "disconnect_at_point = 2, reconnect_after_ms = 3600000";  // not back during the test
  o.extra = fast_reconnect();
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  const auto id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:5"}}});
  ASSERT_EQ(wait_state(c, id, {"paused", "completed"})["state"], "paused");
  // Attempts go on with a growing wait that never exceeds reconnect_max_s.
  ASSERT_TRUE(eventually([&] { return photometer_link(c)["failed_attempts"].get<int>() >= 4; }))
      << g.log_text();
  const auto link = photometer_link(c);
  EXPECT_EQ(link["link"], "down");
  EXPECT_EQ(link["last_errc"], "disconnected");
  EXPECT_NE(link["last_error"].get<std::string>().find("unplugged"), std::string::npos) << link;
  ASSERT_TRUE(link["next_retry_s"].is_number()) << link;
  EXPECT_LE(link["next_retry_s"].get<double>(), 0.2 + 1e-9);
  const auto st = c.call("instrument.status");
  EXPECT_FALSE(st["available"].get<bool>());
  // Manual commands need the devices; the error says which one is missing.
  const auto mv = c.request("instrument.move", json{{"incidence", 30}});
  ASSERT_TRUE(mv.contains("error")) << mv;
  EXPECT_EQ(mv["error"]["data"]["errc"], "disconnected");
  EXPECT_NE(mv["error"]["message"].get<std::string>().find("photometer"), std::string::npos) << mv;
  // A resume queues the scan; it cannot run before the photometer is back.
  c.call("scan.resume", json{{"scan", id}});
  std::this_thread::sleep_for(500ms);
  EXPECT_EQ(c.call("scan.get", json{{"scan", id}})["state"], "queued");
  // instrument.reset works with a device down (a technician who just replugged it) and
  // tries it again at once.
  const auto before = photometer_link(c)["failed_attempts"].get<int>();
  const auto reset = c.request("instrument.reset");
  ASSERT_FALSE(reset.contains("error")) << reset;
  EXPECT_GT(reset["result"]["devices"]["photometer"]["failed_attempts"].get<int>(), before);
}

TEST(Reconnect, AutoResumeFinishesTheScanOnceThePhotometerIsBack) {
  TempDir dir;
  MockOptions o;
  o.faults = "disconnect_at_point = 3, reconnect_after_ms = 300";
  o.extra = fast_reconnect("auto_resume = true\nauto_resume_delay_s = 0\n");
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  const auto id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:5"}}});
  EXPECT_EQ(wait_state(c, id, {"completed", "failed", "cancelled"}, 30s)["state"], "completed")
      << g.log_text();
  expect_each_index_once(all_points(c, id), 13);
  EXPECT_EQ(photometer_link(c)["reconnects"], 1);
}

// The faults that are not a lost link pause the scan and recover by resume alone: no
// device is dropped or reopened.
TEST(Reconnect, OtherScriptedFaultsRecoverByResumeWithoutReopeningADevice) {
  // (A saturated reading is ranged out by a shorter integration time: autorange_test.cpp.)
  for (const std::string fault : {"timeout_at_point = 3, timeout_wait_ms = 50", "stall_at_move = 4",
                                  "garbage_at_point = 2"}) {
    SCOPED_TRACE(fault);
    TempDir dir;
    MockOptions o;
    o.faults = fault;
    o.extra = fast_reconnect();
    Goniod g(dir.path, mock_config(o));
    auto c = g.unix_conn();
    const auto id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:10"}}});  // 7 points
    ASSERT_EQ(wait_state(c, id, {"paused", "completed", "failed"})["state"], "paused") << g.log_text();
    c.call("scan.resume", json{{"scan", id}});
    EXPECT_EQ(wait_state(c, id, {"completed", "paused", "failed"})["state"], "completed") << g.log_text();
    expect_each_index_once(all_points(c, id), 7);
    const auto st = c.call("instrument.status");
    for (const char* side : {"motion", "photometer"}) {
      EXPECT_EQ(st["devices"][side]["link"], "up") << side;
      EXPECT_EQ(st["devices"][side]["reconnects"], 0) << side;
    }
  }
}

// ---- a SCPI photometer on TCP whose device reboots -------------------------------------


TEST(Reconnect, ScpiPhotometerOnTcpIsReopenedAfterTheDeviceReboots) {
  TempDir dir;
  auto sim = std::make_unique<Devsim>(0);
  const int port = sim->port;
  std::ostringstream cfg;
  cfg << "[server]\nlog_level = \"debug\"\n\n" << fast_reconnect("measure_timeout_s = 2\n")
      << "\n[instrument.motion]\ndriver = \"mock\"\n"
      << "\n[instrument.photometer]\ndriver = \"scpi-tcp\"\nhost = \"127.0.0.1\"\nport = " << port
      << "\nconnect_timeout_ms = 500\n\n[twin]\nthreads = 1\nrel_se = 0.01\nreplicates = 8\n";
  Goniod g(dir.path, cfg.str());
  auto c = g.unix_conn();
  ASSERT_TRUE(eventually([&] { return c.call("instrument.status")["available"].get<bool>(); }))
      << g.log_text();
  // The device goes away while goniod is idle: the scan's first reading finds the dead link.
  sim->stop();
  const auto id = submit(c, "plate", "", json{{"grids", {"in=45;out=-30:30:15"}}});  // 5 points
  const auto sc = wait_state(c, id, {"paused", "completed", "failed"});
  ASSERT_EQ(sc["state"], "paused") << sc.dump() << g.log_text();
  ASSERT_TRUE(eventually([&] { return photometer_link(c)["failed_attempts"].get<int>() >= 2; }))
      << g.log_text();
  EXPECT_EQ(photometer_link(c)["link"], "down");
  // Back on the same port: goniod reconnects by itself and the resumed scan completes.
  sim = std::make_unique<Devsim>(port);
  ASSERT_TRUE(eventually([&] { return photometer_link(c)["link"] == "up"; })) << g.log_text();
  EXPECT_EQ(photometer_link(c)["reconnects"], 1);
  c.call("scan.resume", json{{"scan", id}});
  EXPECT_EQ(wait_state(c, id, {"completed", "paused", "failed"})["state"], "completed") << g.log_text();
  expect_each_index_once(all_points(c, id), 5);
}

}  // namespace
}  // namespace gonio::test
