// Auto-ranging against a real goniod and the mock lab: a glossy sample at grazing incidence
// saturates the detector at the nominal 100 ms near the specular direction, and the scan
// completes by itself with the integration time of every point recorded; a dark sample is
// read longer; a beam that saturates even the shortest setting is still a device fault.
#include <algorithm>
#include <cstdio>
#include <map>

#include <spawn.h>
#include <sys/wait.h>

#include <gtest/gtest.h>

#include "gonio/test/daemon_harness.hpp"

extern char** environ;

namespace gonio::test {
namespace {

constexpr const char* kGlossy =
    "lambert:albedo=400:0.06,500:0.12,600:0.45,700:0.55+coat:alpha=0.06,ior=1.5";

json points_of(Conn& c, std::int64_t scan) {
  json all = json::array();
  for (int offset = 0;; offset += 100) {
    const auto page = c.call("scan.points", json{{"scan", scan}, {"offset", offset}, {"limit", 100}})["points"];
    if (page.empty()) return all;
    for (const auto& p : page) all.push_back(p);
  }
}

// integration_ms -> number of points
std::map<double, int> settings(const json& points) {
  std::map<double, int> n;
  for (const auto& p : points) {
    EXPECT_TRUE(p.contains("integration_ms")) << p["index"];
    if (p.contains("integration_ms")) ++n[p["integration_ms"].get<double>()];
  }
  return n;
}

TEST(Autorange, GlossyScanAtGrazingIncidenceCompletesWithoutATechnician) {
  TempDir dir;
  MockOptions o;
  o.true_sample = kGlossy;
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  const auto id = submit(c, "glossy", kGlossy, json{{"grids", {"in=15,45,75;out=-5:85:1"}}});
  const auto sc = wait_state(c, id, {"completed", "paused", "failed"}, 120s);
  ASSERT_EQ(sc["state"], "completed") << sc.dump() << g.log_text();
  const auto points = points_of(c, id);
  ASSERT_EQ(points.size(), 273u);
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_EQ(points[i]["index"], i);
    const auto& flags = points[i]["flags"];
    EXPECT_EQ(std::count(flags.begin(), flags.end(), "saturated"), 0) << i;
  }
  const auto n = settings(points);
  ASSERT_GE(n.size(), 2u) << "some points near the specular direction must have been ranged";
  EXPECT_DOUBLE_EQ(n.rbegin()->first, 100.0);  // the mock's own setting is the nominal one
  EXPECT_LT(n.begin()->first, 100.0);
  // The ranged points still agree with the twin: β does not depend on the setting.
  for (const auto& p : points)
    if (p["integration_ms"].get<double>() < 100.0 && p.contains("z_max") && !p["z_max"].is_null()) {
      EXPECT_LT(p["z_max"].get<double>(), 5.0) << p.dump().substr(0, 300);
    }
  EXPECT_EQ(c.call("instrument.status")["fault_latched"], false);
  // The white read at a shorter setting is compared per unit of integration time: no drift.
  for (const auto& a : c.call("alert.list", json{{"limit", 100}})) EXPECT_NE(a["kind"], "reference_drift") << a.dump();
}

TEST(Autorange, ADarkSampleIsReadLongerWithinTheConfiguredMaximum) {
  TempDir dir;
  MockOptions o;
  o.true_sample = "lambert:albedo=0.0004";
  o.extra = "[instrument]\nintegration_max_ms = 1000\n";
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  const auto id = submit(c, "black", "lambert:albedo=0.0004", json{{"grids", {"in=45;out=-30:30:10"}}});
  ASSERT_EQ(wait_state(c, id, {"completed", "paused", "failed"}, 60s)["state"], "completed") << g.log_text();
  const auto n = settings(points_of(c, id));
  ASSERT_FALSE(n.empty());
  EXPECT_GT(n.begin()->first, 100.0);
  EXPECT_LE(n.rbegin()->first, 1000.0);
}

TEST(Autorange, TheShortestSettingStillSaturatedIsADeviceFault) {
  TempDir dir;
  MockOptions o;
  o.lab = "full_scale_counts = 300\n";  // below the reference white's signal at 1 ms
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  const auto id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:10"}}});
  const auto sc = wait_state(c, id, {"completed", "paused", "failed"}, 60s);
  ASSERT_EQ(sc["state"], "paused") << g.log_text();
  EXPECT_NE(sc["reason"].get<std::string>().find("shortest integration time"), std::string::npos) << sc["reason"];
  EXPECT_EQ(c.call("scan.points", json{{"scan", id}, {"offset", 0}, {"limit", 10}})["points"].size(), 0u);
}

TEST(Autorange, OffASaturatedReadingPausesTheScanAsBefore) {
  TempDir dir;
  MockOptions o;
  o.true_sample = kGlossy;
  o.extra = "[instrument]\nautorange = false\n";
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  const auto id = submit(c, "glossy", kGlossy, json{{"grids", {"in=75;out=60:85:5"}}});
  const auto sc = wait_state(c, id, {"completed", "paused", "failed"}, 60s);
  ASSERT_EQ(sc["state"], "paused") << g.log_text();
  EXPECT_NE(sc["reason"].get<std::string>().find("saturated"), std::string::npos) << sc["reason"];
}

// gonio-devsim's SCPI photometer on TCP with the given simulator config.
std::unique_ptr<Devsim> scpi_devsim(const fs::path& dir, const json& config) {
  const auto cfg = (dir / "scpi.json").string();
  std::ofstream(cfg) << config.dump();
  return std::make_unique<Devsim>(0, std::vector<std::string>{"--scpi-config", cfg});
}

// The real SCPI driver against gonio-devsim: its reference white saturates at the nominal
// 100 ms (50000 counts against a full scale of 20000), so every point is ranged to 25 ms.
TEST(Autorange, ScpiPhotometerOnGonioDevsimIsRangedThroughItsIntegrationTime) {
  TempDir dir;
  const auto sim = scpi_devsim(dir.path, json{{"full_scale_counts", 20000}});
  std::ostringstream cfg;
  cfg << "[server]\nlog_level = \"debug\"\n\n[instrument.motion]\ndriver = \"mock\"\n"
      << "\n[instrument.photometer]\ndriver = \"scpi-tcp\"\nhost = \"127.0.0.1\"\nport = " << sim->port
      << "\n\n[twin]\nthreads = 1\nrel_se = 0.01\nreplicates = 8\n";
  Goniod g(dir.path / "state", cfg.str());
  auto c = g.unix_conn();
  const auto id = submit(c, "plate", "", json{{"grids", {"in=45;out=-30:30:15"}}});  // 5 points
  ASSERT_EQ(wait_state(c, id, {"completed", "paused", "failed"}, 60s)["state"], "completed") << g.log_text();
  const auto n = settings(points_of(c, id));
  ASSERT_EQ(n.size(), 1u);
  EXPECT_DOUBLE_EQ(n.begin()->first, 25.0);
  EXPECT_EQ(n.begin()->second, 5);
}

// The photometer's own shortest setting (50 ms) is above the configured one: a reading that
// still saturates there is a fault that says so, not an out-of-range error.
TEST(Autorange, APhotometerThatRefusesAShorterSettingEndsTheRangingWithASaturationFault) {
  TempDir dir;
  const auto sim = scpi_devsim(dir.path, json{{"full_scale_counts", 20000}, {"min_integration_ms", 50}});
  std::ostringstream cfg;
  cfg << "[server]\nlog_level = \"debug\"\n\n[instrument.motion]\ndriver = \"mock\"\n"
      << "\n[instrument.photometer]\ndriver = \"scpi-tcp\"\nhost = \"127.0.0.1\"\nport = " << sim->port
      << "\n\n[twin]\nthreads = 1\nrel_se = 0.01\nreplicates = 8\n";
  Goniod g(dir.path / "state", cfg.str());
  auto c = g.unix_conn();
  const auto id = submit(c, "plate", "", json{{"grids", {"in=45;out=0"}}});
  const auto sc = wait_state(c, id, {"completed", "paused", "failed"}, 60s);
  ASSERT_EQ(sc["state"], "paused") << g.log_text();
  EXPECT_NE(sc["reason"].get<std::string>().find("refuses a shorter integration time"), std::string::npos)
      << sc["reason"];
}

}  // namespace
}  // namespace gonio::test
