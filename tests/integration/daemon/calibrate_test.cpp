// instrument.calibrate and the diagnosis of a sustained divergence against a real goniod on
// the mock, whose lab hides an instrument fault the configured profile does not know about:
//  - a receive arm that stands 1° off what it reports (twice its ±0.5° data sheet): the scan
//    of a known glossy sample is judged instrument_out_of_spec, naming the receive arm; the
//    calibration finds the offset, the corrected profile is stored as version 1,
//    the next scan of the same sample agrees with the twin, and a restarted goniod keeps it;
//  - a reference white 20 % off: the verdict names the gain, and the diagnosis refits it
//    through the inverse twin at the end of the scan.
#include <gtest/gtest.h>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

constexpr const char* kGlossy = "conductor:alpha=0.08,eta=0.2,k=3.9";

json glossy_plan() {
  return json{{"grids", {"in=45;out=25:65:2"}}, {"wavelengths", "450,550,650"}};
}

std::int64_t completed_scan(Conn& c, const std::string& sample, const std::string& bsdf) {
  const auto id = submit(c, sample, bsdf, glossy_plan());
  const auto sc = wait_state(c, id, {"completed", "failed", "paused"}, 60s);
  EXPECT_EQ(sc["state"], "completed") << sc.dump();
  return id;
}

MockOptions lab_with(const std::string& hidden) {
  MockOptions o;
  o.true_sample = kGlossy;
  // The specular peak must not saturate the detector.
  o.lab = "full_scale_counts = 1e12\n" + hidden;
  return o;
}

// 1.5° off: beyond what the two arms within their ±0.5° together can mimic (a receive arm
// 1° off at this lobe is, to 0.1 %, both arms at their limits, so the verdict says agrees).
MockOptions offset_lab() { return lab_with("arm_offsets_deg = { receive = -1.5 }\n"); }

TEST(InstrumentCalibrate, FindsAHiddenReceiveOffsetAndTheDivergenceVanishes) {
  TempDir dir;
  auto g = std::make_unique<Goniod>(dir.path, mock_config(offset_lab()));
  auto c = g->unix_conn();
  const auto before = c.call("instrument.status");
  EXPECT_EQ(before["profile"]["version"], 0) << before.dump();
  EXPECT_TRUE(before["profile"]["calibrated_at"].is_null());

  const auto first = completed_scan(c, "artifact", kGlossy);
  const auto diverged = c.call("scan.get", json{{"scan", first}})["points_diverged"].get<int>();
  ASSERT_GT(diverged, 0) << "the hidden offset must show as a divergence";
  const auto verdict = c.call("scan.get", json{{"scan", first}})["verdict"];
  EXPECT_EQ(verdict["decision"], "instrument_out_of_spec") << verdict.dump();
  ASSERT_TRUE(verdict["cause"].is_object()) << verdict.dump();
  EXPECT_EQ(verdict["cause"]["parameter"], "receive_arm_deg") << verdict.dump();
  EXPECT_NEAR(verdict["cause"]["value"].get<double>(), -1.5, 0.25) << verdict.dump();

  const auto cal = c.call("instrument.calibrate",
                          json{{"scan", first}, {"fit", {"receive_offset_deg"}}, {"samples", 4096}});
  ASSERT_EQ(cal["kind"], "calibrate") << cal.dump();
  EXPECT_TRUE(cal["applied"].get<bool>()) << cal.dump();
  const auto& p = cal["result"]["parameters"][0];
  EXPECT_EQ(p["name"], "receive_offset_deg");
  EXPECT_NEAR(p["value"].get<double>(), -1.5, std::max(4 * p["u"].get<double>(), 0.05)) << cal.dump();
  EXPECT_EQ(cal["profile"]["version"], 1);
  const auto status = c.call("instrument.status");
  EXPECT_EQ(status["profile"]["version"], 1) << status.dump();
  EXPECT_TRUE(status["profile"]["calibrated_at"].is_string());

  // The same artifact again: now predicted with the corrected profile, which the points record.
  const auto second = completed_scan(c, "artifact", kGlossy);
  const auto sc = c.call("scan.get", json{{"scan", second}});
  EXPECT_EQ(sc["points_diverged"], 0)
      << cal.dump() << c.call("scan.points", json{{"scan", second}, {"limit", 100}}).dump();
  EXPECT_NE(sc["verdict"]["decision"], "instrument_out_of_spec") << sc["verdict"].dump();
  EXPECT_NE(sc["verdict"]["decision"], "out_of_tolerance") << sc["verdict"].dump();
  const auto pts = c.call("scan.points", json{{"scan", second}, {"limit", 1}});
  EXPECT_NE(pts["points"][0]["twin_version"].get<std::string>().find("profile=gcms4#1"),
            std::string::npos) << pts.dump();

  // The calibration is stored with the first scan and survives a restart.
  const auto fits = c.call("scan.get", json{{"scan", first}})["fits"];
  EXPECT_TRUE(std::any_of(fits.begin(), fits.end(), [](const json& f) { return f["kind"] == "calibrate"; }))
      << fits.dump();
  EXPECT_EQ(g->stop(), 0);
  g.reset();
  Goniod again(dir.path, mock_config(offset_lab()));
  auto c2 = again.unix_conn();
  EXPECT_EQ(c2.call("instrument.status")["profile"]["version"], 1);
}

TEST(InstrumentCalibrate, DryRunAndBadParamsKeepTheProfile) {
  TempDir dir;
  Goniod g(dir.path, mock_config(lab_with("")));
  auto c = g.unix_conn();
  const auto id = completed_scan(c, "artifact", kGlossy);
  struct Case {
    json params;
    int code;
    std::string field;
  };
  const std::vector<Case> cases{
      {json{{"scan", 999}, {"fit", {"gain"}}}, -32002, "scan"},
      {json{{"scan", id}}, -32602, "fit"},
      {json{{"scan", id}, {"fit", json::array()}}, -32602, "fit"},
      {json{{"scan", id}, {"fit", {"gain", "bogus"}}}, -32602, "fit[1]"},
      {json{{"scan", id}, {"fit", {"gain", "gain"}}}, -32602, "fit[1]"},
      {json{{"scan", id}, {"fit", {"gain"}}, {"sample", "nonsense:x=1"}}, -32602, "sample"},
      {json{{"scan", id}, {"fit", {"gain"}}, {"samples", 10}}, -32602, "samples"},
  };
  for (const auto& bc : cases) {
    const auto r = c.request("instrument.calibrate", bc.params);
    ASSERT_TRUE(r.contains("error")) << bc.params.dump() << " -> " << r.dump();
    EXPECT_EQ(r["error"]["code"], bc.code) << r.dump();
    EXPECT_EQ(r["error"]["data"].value("field", std::string()).substr(0, bc.field.size()), bc.field)
        << r.dump();
  }
  const auto dry = c.call("instrument.calibrate",
                          json{{"scan", id}, {"fit", {"gain"}}, {"samples", 2048}, {"dry_run", true}});
  EXPECT_FALSE(dry["applied"].get<bool>());
  EXPECT_EQ(dry["reason"], "dry run");
  EXPECT_NEAR(dry["result"]["parameters"][0]["value"].get<double>(), 1.0, 0.02) << dry.dump();
  EXPECT_EQ(c.call("instrument.status")["profile"]["version"], 0);
}

TEST(DivergenceDiagnosis, TheVerdictNamesAReferenceWhiteGainAndTheInverseTwinRefitsIt) {
  TempDir dir;
  Goniod g(dir.path, mock_config(lab_with("gain = 1.2\n")));
  auto c = g.unix_conn();
  const auto id = completed_scan(c, "artifact", kGlossy);
  const auto verdict = c.call("scan.get", json{{"scan", id}})["verdict"];
  EXPECT_EQ(verdict["decision"], "instrument_out_of_spec") << verdict.dump();
  ASSERT_TRUE(verdict["cause"].is_object()) << verdict.dump();
  EXPECT_EQ(verdict["cause"]["parameter"], "gain");
  EXPECT_NEAR(verdict["cause"]["value"].get<double>(), 1.2, 0.02) << verdict.dump();
  json sustained;
  const bool diagnosed = eventually(
      [&] {
        for (const auto& a : c.call("alert.list", json{{"scan", id}}))
          if (a["kind"] == "sustained_divergence" &&
              a["message"].get<std::string>().find("diagnosis") != std::string::npos) {
            sustained = a;
            return true;
          }
        return false;
      },
      120s);
  ASSERT_TRUE(diagnosed) << c.call("alert.list", json{{"scan", id}}).dump() << g.log_text();
  const auto msg = sustained["message"].get<std::string>();
  const std::string said = "the inverse twin refits gain to ";
  const auto at = msg.find(said);
  ASSERT_NE(at, std::string::npos) << msg;
  EXPECT_NEAR(std::stod(msg.substr(at + said.size())), 1.2, 0.01) << msg;
  EXPECT_EQ(sustained["count"].get<int>() >= 1, true);
  const auto fits = c.call("scan.get", json{{"scan", id}})["fits"];
  ASSERT_FALSE(fits.empty());
  EXPECT_EQ(fits[0]["kind"], "diagnosis");
  EXPECT_EQ(fits[0]["result"]["cause"]["parameter"], "gain") << fits[0].dump();
  // One sustained alert for the scan, updated as the verdict firmed up, never a second.
  int n = 0;
  for (const auto& a : c.call("alert.list", json{{"scan", id}})) n += a["kind"] == "sustained_divergence";
  EXPECT_EQ(n, 1);
}

}  // namespace
}  // namespace gonio::test
