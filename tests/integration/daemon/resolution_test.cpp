// Alerts follow the final verdict, against a real goniod on the mock (docs/decision-rule.md,
// "The rule for a scan"). A painted sample's first points see its red albedo node 2.6 % above
// the catalogue (1.3× its tolerance: out of it as the verdict's fitted change, within each
// point's own k·u of it, so no point is out of tolerance on its own): the verdict names it mid-scan, raises the sustained
// alert, and goniod pauses the scan (divergence.pause_on_sustained). goniod is restarted on a
// lab whose sample is:
//  - as catalogued (the first points were the odd ones out): the scan resumes, its final
//    verdict over every point no longer alerts, and the alert is resolved — resolved_at,
//    the resolution with the final summary, an `alert` notification to a subscriber,
//    alert.list's standing/resolved filter and gonioctl's table of resolved alerts. The plan
//    measures a coarse grid first and a fine one after, so the odd points are spread thinly
//    over the whole range: no stretch of the scan is mostly made of them;
//  - still 2.6 % above: the final verdict alerts, and the alert stands;
//  - as catalogued, and the scan cancelled once its verdict stops alerting: the verdict on
//    the points it has is final, and resolves the alert.
#include <gtest/gtest.h>

#include <cstdio>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

constexpr const char* kCatalogue = "lambert:albedo=400:0.06,500:0.12,600:0.45,700:0.55";
constexpr const char* kOff = "lambert:albedo=400:0.06,500:0.12,600:0.4617,700:0.55";
const json kGrids = {"in=45;out=-30:30:4", "in=45;out=-29.5:29.5:0.5"};  // 16 + 119 points

std::string config(const std::string& hidden_sample, double time_scale = 0) {
  MockOptions o;
  o.true_sample = hidden_sample;
  o.time_scale = time_scale;
  o.lab = "full_scale_counts = 1e12\nposition_repeatability_deg = 0.05\n";
  o.extra = "[divergence]\npause_on_sustained = true\n";
  return mock_config(o);
}

json sustained_of(Conn& c, std::int64_t scan, const std::string& state) {
  json out = json::array();
  for (const auto& a : c.call("alert.list", json{{"scan", scan}, {"state", state}}))
    if (a["kind"] == "sustained_divergence") out.push_back(a);
  return out;
}

bool alerting(const json& verdict) {
  return verdict["decision"] == "out_of_tolerance" || verdict["decision"] == "instrument_out_of_spec";
}

// The scan on the paint whose red is 2.6 % off, paused by its sustained alert; goniod stopped.
// Returns the scan's id.
std::int64_t raise_mid_scan(const TempDir& dir) {
  std::int64_t id = 0;
  Goniod g(dir.path, config(kOff));
  auto c = g.unix_conn();
  id = submit(c, "paint", kCatalogue, json{{"grids", kGrids}, {"wavelengths", "450:650:50"}});
  const auto sc = wait_state(c, id, {"paused", "completed", "failed"}, 120s);
  EXPECT_EQ(sc["state"], "paused") << sc.dump();
  EXPECT_LE(sc["points_done"].get<int>(), 16) << "the alert came after the coarse grid: " << sc.dump();
  EXPECT_TRUE(alerting(sc["verdict"])) << sc["verdict"].dump();
  const auto standing = sustained_of(c, id, "standing");
  EXPECT_EQ(standing.size(), 1u) << c.call("alert.list", json{{"scan", id}}).dump();
  EXPECT_TRUE(sustained_of(c, id, "resolved").empty());
  if (!standing.empty()) {
    EXPECT_TRUE(standing[0]["resolved_at"].is_null());
    EXPECT_TRUE(standing[0]["resolution"].is_null());
  }
  EXPECT_EQ(g.stop(), 0) << g.log_text();
  return id;
}

std::string gonioctl_out(const fs::path& state_dir, const std::string& args) {
  const auto cmd = std::string(GONIO_BIN_DIR) + "/gonioctl --state-dir '" + state_dir.string() + "' " +
                   args + " 2>&1";
  std::string out;
  FILE* p = ::popen(cmd.c_str(), "r");
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  ::pclose(p);
  return out;
}

TEST(Resolution, AnAlertTheFinalVerdictNoLongerSupportsIsResolvedAndPublished) {
  TempDir dir;
  const auto id = raise_mid_scan(dir);
  Goniod g(dir.path, config(kCatalogue));
  auto c = g.unix_conn();
  auto sub = g.unix_conn();
  sub.call("subscribe", json{{"topics", {"alerts"}}});
  c.call("scan.resume", json{{"scan", id}});
  const auto sc = wait_state(c, id, {"completed", "failed", "paused"}, 120s);
  ASSERT_EQ(sc["state"], "completed") << sc.dump();
  const auto& v = sc["verdict"];
  ASSERT_FALSE(alerting(v)) << "the odd first points outweighed the rest: " << v.dump();

  const auto resolved = sustained_of(c, id, "resolved");
  ASSERT_EQ(resolved.size(), 1u) << c.call("alert.list", json{{"scan", id}}).dump();
  const auto& a = resolved[0];
  EXPECT_TRUE(a["resolved_at"].is_string());
  EXPECT_GE(a["resolved_at"].get<std::string>(), a["last_at"].get<std::string>());
  EXPECT_EQ(a["resolution"], "resolved: final verdict " + v["decision"].get<std::string>() + ": " +
                                 v["summary"].get<std::string>());
  EXPECT_EQ(a["severity"], "critical");  // what was seen stays as it was
  EXPECT_TRUE(sustained_of(c, id, "standing").empty());
  EXPECT_EQ(sustained_of(c, id, "all").size(), 1u);
  const auto bad = c.request("alert.list", json{{"state", "open"}});
  EXPECT_EQ(bad["error"]["data"]["field"], "state") << bad.dump();

  // The subscriber was told, with the alert as stored.
  bool told = false;
  while (auto n = sub.notification(2s))
    if (const auto& p = (*n)["params"];
        (*n)["method"] == "alert" && p["id"] == a["id"] && !p["resolved_at"].is_null()) {
      EXPECT_EQ(p["resolution"], a["resolution"]);
      told = true;
    }
  EXPECT_TRUE(told) << g.log_text();

  // gonioctl lists it apart, with its resolution.
  const auto table = gonioctl_out(dir.path, "alert list --scan " + std::to_string(id));
  const auto apart = table.find("resolved:");
  ASSERT_NE(apart, std::string::npos) << table;
  EXPECT_NE(table.find("resolved: final verdict", apart + 1), std::string::npos) << table;
}

TEST(Resolution, AnAlertTheFinalVerdictSupportsStands) {
  TempDir dir;
  const auto id = raise_mid_scan(dir);
  Goniod g(dir.path, config(kOff));
  auto c = g.unix_conn();
  c.call("scan.resume", json{{"scan", id}});
  const auto sc = wait_state(c, id, {"completed", "failed", "paused"}, 120s);
  ASSERT_EQ(sc["state"], "completed") << sc.dump();
  EXPECT_TRUE(alerting(sc["verdict"])) << sc["verdict"].dump();
  const auto standing = sustained_of(c, id, "standing");
  ASSERT_EQ(standing.size(), 1u) << c.call("alert.list", json{{"scan", id}}).dump();
  EXPECT_TRUE(standing[0]["resolved_at"].is_null());
  EXPECT_TRUE(standing[0]["resolution"].is_null());
  EXPECT_TRUE(sustained_of(c, id, "resolved").empty());
}

TEST(Resolution, ACancelledScanIsJudgedOnThePointsItHas) {
  TempDir dir;
  const auto id = raise_mid_scan(dir);
  Goniod g(dir.path, config(kCatalogue, 0.5));  // moves and readings take wall time
  auto c = g.unix_conn();
  c.call("scan.resume", json{{"scan", id}});
  json sc;
  ASSERT_TRUE(eventually([&] {
    sc = c.call("scan.get", json{{"scan", id}});
    return sc["state"] == "running" && sc["points_done"].get<int>() > 16 && !alerting(sc["verdict"]);
  }, 60s)) << sc.dump();
  ASSERT_EQ(c.call("scan.cancel", json{{"scan", id}})["state"], "cancelled");
  const auto v = c.call("scan.get", json{{"scan", id}})["verdict"];
  ASSERT_FALSE(alerting(v)) << v.dump();
  const auto resolved = sustained_of(c, id, "resolved");
  ASSERT_EQ(resolved.size(), 1u) << c.call("alert.list", json{{"scan", id}}).dump();
  EXPECT_EQ(resolved[0]["resolution"], "resolved: final verdict " + v["decision"].get<std::string>() +
                                           ": " + v["summary"].get<std::string>());
}

}  // namespace
}  // namespace gonio::test
