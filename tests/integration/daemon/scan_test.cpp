// A whole scan on the mock through a real goniod: measured beside predicted, notifications,
// paging, exports, samples without a BSDF, plan rejection, the queue, and that scan.state
// notifications carry the reason that was stored.
#include <gtest/gtest.h>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

TEST(Scan, FullScanOnTheMockStoresMeasuredAndPredicted) {
  TempDir dir;
  Goniod g(dir.path, mock_config({}));
  auto c = g.unix_conn();
  auto watcher = g.unix_conn();
  watcher.call("subscribe", json{{"topics", {"progress", "points", "state"}}});
  const auto id = submit(c, "white-tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:5"}}, {"wavelengths", "400:700:20"}});
  const auto sc = wait_state(c, id, {"completed", "failed", "paused"});
  ASSERT_EQ(sc["state"], "completed") << sc.dump() << g.log_text();
  EXPECT_EQ(sc["points_total"], 13);
  EXPECT_EQ(sc["points_done"], 13);
  EXPECT_TRUE(sc["predicted"].get<bool>());

  // Notifications: one scan.point per point, progress up to completion.
  std::set<long long> seen;
  bool completed = false;
  while (auto n = watcher.notification(2s)) {
    if ((*n)["method"] == "scan.point") seen.insert((*n)["params"]["index"].get<long long>());
    if ((*n)["method"] == "scan.progress" && (*n)["params"]["state"] == "completed") completed = true;
  }
  EXPECT_EQ(seen.size(), 13u);
  EXPECT_TRUE(completed);

  // Pages, in order, each point with both spectra and the divergence figures.
  const auto p1 = c.call("scan.points", json{{"scan", id}, {"offset", 0}, {"limit", 5}});
  ASSERT_EQ(p1["points"].size(), 5u);
  EXPECT_EQ(p1["next_offset"], 5);
  const auto p3 = c.call("scan.points", json{{"scan", id}, {"offset", 10}, {"limit", 5}});
  ASSERT_EQ(p3["points"].size(), 3u);
  EXPECT_TRUE(p3["next_offset"].is_null());
  for (const auto& p : p1["points"]) {
    EXPECT_EQ(p["measured"]["values"].size(), 16u);
    ASSERT_FALSE(p["predicted"].is_null());
    EXPECT_EQ(p["predicted"]["values"].size(), 16u);
    EXPECT_FALSE(p["twin_version"].get<std::string>().empty());
    EXPECT_TRUE(p["z_max"].is_number());
    EXPECT_TRUE(p["delta_e00"].is_number());
    EXPECT_NEAR(p["actual"]["theta_i"].get<double>(), 45, 1e-6);
  }
  // A Lambertian tile with albedo 0.6: measured β near 0.6 and close to the twin's value.
  const auto& mid = p1["points"][3];  // θr = −30
  EXPECT_NEAR(mid["measured"]["values"][5].get<double>(), 0.6, 0.05);
  EXPECT_NEAR(mid["predicted"]["values"][5].get<double>(), 0.6, 0.05);
  EXPECT_EQ(c.call("queue.status")["running"], nullptr);

  // Exports.
  const auto csv = c.call("scan.export", json{{"scan", id}, {"format", "csv"}});
  EXPECT_EQ(csv["points"], 13);
  EXPECT_NE(csv["content"].get<std::string>().find("wavelength_nm"), std::string::npos);
  // The last column is the integration time each point was read at (the mock's is settable).
  {
    const auto text = csv["content"].get<std::string>();
    const auto header = text.find("index,");
    ASSERT_NE(header, std::string::npos);
    const auto header_end = text.find('\n', header);
    EXPECT_TRUE(text.substr(header, header_end - header).ends_with(",flags,integration_ms"));
    const auto row_end = text.find('\n', header_end + 1);
    const auto row = text.substr(header_end + 1, row_end - header_end - 1);
    const auto last = row.substr(row.find_last_of(',') + 1);
    EXPECT_FALSE(last.empty()) << row;
    EXPECT_GT(std::stod(last), 0) << row;
  }
  const auto ssdd = c.call("scan.export", json{{"scan", id}, {"format", "ssdd"}});
  EXPECT_NE(ssdd["content"].get<std::string>().find("DATA_TYPE brdf"), std::string::npos)
      << ssdd["content"].get<std::string>().substr(0, 200);
  EXPECT_NE(c.call("scan.export", json{{"scan", id}, {"format", "bsdf"}})["content"].get<std::string>().find("ScatterType"),
            std::string::npos);
  const auto js = json::parse(c.call("scan.export", json{{"scan", id}, {"format", "json"}})["content"].get<std::string>());
  EXPECT_EQ(js["points"].size(), 13u);
  EXPECT_EQ(g.stop(), 0);
}

TEST(Scan, SampleWithoutBsdfIsMeasuredWithoutPredictionsAndSaysSo) {
  TempDir dir;
  Goniod g(dir.path, mock_config({}));
  auto c = g.unix_conn();
  c.call("sample.create", json{{"name", "unknown"}, {"bsdf", nullptr}});
  const auto s = c.call("scan.submit", json{{"sample", "unknown"}, {"geometries", {"45as15", "45as45"}}});
  EXPECT_FALSE(s["predicted"].get<bool>());
  EXPECT_NE(s["note"].get<std::string>().find("without predictions"), std::string::npos);
  const auto id = s["id"].get<std::int64_t>();
  ASSERT_EQ(wait_state(c, id, {"completed", "paused", "failed"})["state"], "completed");
  for (const auto& p : c.call("scan.points", json{{"scan", id}})["points"]) {
    EXPECT_TRUE(p["predicted"].is_null());
    EXPECT_NE(std::find(p["flags"].begin(), p["flags"].end(), "no_prediction"), p["flags"].end());
  }
}

TEST(Scan, PlansBreakingInstrumentLimitsAreRejectedNamingTheGeometry) {
  TempDir dir;
  MockOptions o;
  o.extra = "[instrument.limits]\nmin_separation = 10\n";
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  c.call("sample.create", json{{"name", "s"}, {"bsdf", kTrueSample}});
  // θr = −88 is beyond the receive arm's soft limit (±85 by default).
  auto r = c.request("scan.submit", json{{"sample", "s"}, {"geometries", {"45/0", "45/10", "45/-88"}}});
  EXPECT_EQ(r["error"]["code"], -32006) << r.dump();
  EXPECT_EQ(r["error"]["data"]["field"], "geometries[2]");
  EXPECT_NE(r["error"]["message"].get<std::string>().find("85"), std::string::npos) << r.dump();
  // θr = −40 at θi = 45 puts the arms 5° apart, inside the 10° collision zone.
  r = c.request("scan.submit", json{{"sample", "s"}, {"geometries", {"45/0", "45/-40"}}});
  EXPECT_EQ(r["error"]["code"], -32006);
  EXPECT_EQ(r["error"]["data"]["field"], "geometries[1]");
  EXPECT_NE(r["error"]["message"].get<std::string>().find("collision"), std::string::npos) << r.dump();
  // Outside the photometer's wavelengths (the mock reads 400–700 nm).
  r = c.request("scan.submit", json{{"sample", "s"}, {"geometries", {"45/0"}}, {"wavelengths", "350:700:10"}});
  EXPECT_EQ(r["error"]["code"], -32006);
  EXPECT_EQ(r["error"]["data"]["field"], "wavelengths");
  EXPECT_TRUE(c.call("scan.list").empty());  // nothing was queued
}

TEST(Scan, QueueOrderPauseResumeCancelAndNotBefore) {
  TempDir dir;
  MockOptions o;
  o.time_scale = 0.05;
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  c.call("sample.create", json{{"name", "s"}, {"bsdf", kTrueSample}});
  const auto plan = json{{"sample", "s"}, {"grids", {"in=30;out=-18:78:4"}}};
  const auto first = c.call("scan.submit", plan)["id"].get<std::int64_t>();
  ASSERT_EQ(wait_state(c, first, {"running"})["state"], "running");
  auto later = plan;
  later["not_before"] = "2099-01-01T00:00:00Z";
  const auto held = c.call("scan.submit", later)["id"].get<std::int64_t>();
  const auto low = c.call("scan.submit", plan)["id"].get<std::int64_t>();
  auto urgent = plan;
  urgent["priority"] = 10;
  const auto high = c.call("scan.submit", urgent)["id"].get<std::int64_t>();
  auto waiting = c.call("queue.status")["waiting"];
  ASSERT_EQ(waiting.size(), 3u);
  EXPECT_EQ(waiting[0]["id"], high);  // priority first
  c.call("queue.reorder", json{{"scan", low}, {"position", 0}});
  EXPECT_EQ(c.call("queue.status")["waiting"][0]["id"], low);

  // Pausing the running scan takes effect after its point in progress.
  const auto paused = c.call("scan.pause", json{{"scan", first}, {"reason", "lunch"}});
  EXPECT_EQ(paused["state"], "paused");
  EXPECT_EQ(paused["reason"], "lunch");
  const auto done_at_pause = paused["points_done"].get<int>();
  EXPECT_EQ(wait_state(c, low, {"running", "completed"})["state"].is_string(), true);
  c.call("scan.cancel", json{{"scan", high}});
  EXPECT_EQ(c.call("scan.get", json{{"scan", high}})["state"], "cancelled");
  auto r = c.request("scan.resume", json{{"scan", high}});
  EXPECT_EQ(r["error"]["code"], -32003);
  c.call("scan.resume", json{{"scan", first}});
  EXPECT_EQ(wait_state(c, first, {"completed"}, 30s)["state"], "completed");
  EXPECT_EQ(wait_state(c, low, {"completed"}, 30s)["state"], "completed");
  const auto pts = c.call("scan.points", json{{"scan", first}, {"limit", 1000}})["points"];
  EXPECT_EQ(pts.size(), 25u);
  EXPECT_GT(done_at_pause, 0);
  for (std::size_t i = 0; i < pts.size(); ++i) EXPECT_EQ(pts[i]["index"], i);
  EXPECT_EQ(c.call("scan.get", json{{"scan", held}})["state"], "queued");  // its time has not come
}

// The next scan.state notification for `scan` entering `state`, skipping everything else.
std::optional<json> next_scan_state(Conn& watcher, std::int64_t scan, const std::string& state) {
  while (auto n = watcher.notification(10s)) {
    if ((*n)["method"] == "scan.state" && (*n)["params"]["scan"] == scan &&
        (*n)["params"]["state"] == state)
      return (*n)["params"];
  }
  return std::nullopt;
}

TEST(Scan, StateNotificationsCarryTheReasonThatWasStored) {
  TempDir dir;
  MockOptions o;
  o.time_scale = 0.05;
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  auto watcher = g.unix_conn();
  watcher.call("subscribe", json{{"topics", {"state"}}});
  c.call("sample.create", json{{"name", "s"}, {"bsdf", kTrueSample}});
  const auto plan = json{{"sample", "s"}, {"grids", {"in=30;out=-18:78:4"}}};
  const auto running = c.call("scan.submit", plan)["id"].get<std::int64_t>();
  ASSERT_EQ(wait_state(c, running, {"running"})["state"], "running");
  auto later = plan;
  later["not_before"] = "2099-01-01T00:00:00Z";
  const auto held = c.call("scan.submit", later)["id"].get<std::int64_t>();

  // A queued scan paused without a reason: the stored reason names who paused it, and the
  // notification says the same.
  const auto paused = c.call("scan.pause", json{{"scan", held}});
  ASSERT_EQ(paused["state"], "paused");
  const auto stored = paused["reason"].get<std::string>();
  EXPECT_NE(stored.find("paused by"), std::string::npos) << stored;
  auto n = next_scan_state(watcher, held, "paused");
  ASSERT_TRUE(n) << "no scan.state notification for the pause";
  EXPECT_EQ((*n)["reason"], stored);
  EXPECT_EQ(c.call("scan.get", json{{"scan", held}})["reason"], stored);

  // Resuming it: "resumed by …", stored and published.
  const auto queued = c.call("scan.resume", json{{"scan", held}});
  n = next_scan_state(watcher, held, "queued");
  ASSERT_TRUE(n);
  EXPECT_NE(queued["reason"].get<std::string>().find("resumed by"), std::string::npos)
      << queued.dump();
  EXPECT_EQ((*n)["reason"], queued["reason"]);

  // The running scan paused without a reason, applied by the runner after its point.
  for (int i = 0; i < 400 && c.call("scan.get", json{{"scan", running}})["points_done"] == 0; ++i)
    std::this_thread::sleep_for(25ms);
  const auto paused_run = c.call("scan.pause", json{{"scan", running}});
  ASSERT_EQ(paused_run["state"], "paused");
  n = next_scan_state(watcher, running, "paused");
  ASSERT_TRUE(n);
  EXPECT_NE(paused_run["reason"].get<std::string>().find("paused by"), std::string::npos);
  EXPECT_EQ((*n)["reason"], paused_run["reason"]);

  // Resumed, it restarts where it stopped and says so in both places.
  c.call("scan.resume", json{{"scan", running}});
  n = next_scan_state(watcher, running, "running");
  ASSERT_TRUE(n);
  EXPECT_EQ((*n)["reason"].get<std::string>().rfind("resumed at point ", 0), 0u) << n->dump();
  const auto now = c.call("scan.get", json{{"scan", running}});
  if (now["state"] == "running") {
    EXPECT_EQ((*n)["reason"], now["reason"]);
  }

  // A queued scan cancelled without a reason.
  const auto cancelled = c.call("scan.cancel", json{{"scan", held}});
  n = next_scan_state(watcher, held, "cancelled");
  ASSERT_TRUE(n);
  EXPECT_NE(cancelled["reason"].get<std::string>().find("cancelled by"), std::string::npos);
  EXPECT_EQ((*n)["reason"], cancelled["reason"]);
  c.call("scan.cancel", json{{"scan", running}});
  EXPECT_EQ(g.stop(), 0);
}

}  // namespace
}  // namespace gonio::test
