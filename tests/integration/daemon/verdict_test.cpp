// Alerts a technician can trust, against a real goniod on the mock whose hidden lab differs
// from the catalogue in a known way (docs/decision-rule.md):
//  - an instrument within its data sheet (receive arm 0.3° off, ±0.5° stated, arms
//    repeatable to ±0.05°) and a glossy sample exactly as catalogued: no sustained alert;
//  - a painted sample whose red albedo node is 4 % above the catalogue (twice its 2 %
//    tolerance): out of tolerance, the red albedo named, points judged per point too;
//  - a glossy sample roughened by 10 %: out of tolerance, the roughness named, not a gain.
#include <gtest/gtest.h>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

constexpr const char* kGlossy = "conductor:alpha=0.05,eta=0.2,k=3.9";
constexpr const char* kPaint = "lambert:albedo=400:0.06,500:0.12,600:0.45,700:0.55";

MockOptions lab(const std::string& hidden_sample, const std::string& keys) {
  MockOptions o;
  o.true_sample = hidden_sample;
  o.lab = "full_scale_counts = 1e12\nposition_repeatability_deg = 0.05\n" + keys;
  return o;
}

json run(Conn& c, const std::string& bsdf, const std::string& grid) {
  const auto id = submit(c, "sample", bsdf, json{{"grids", {grid}}, {"wavelengths", "450:650:50"}});
  auto sc = wait_state(c, id, {"completed", "failed", "paused"}, 120s);
  EXPECT_EQ(sc["state"], "completed") << sc.dump();
  sc["alerts"] = c.call("alert.list", json{{"scan", id}});
  sc["first_points"] = c.call("scan.points", json{{"scan", id}, {"limit", 2}})["points"];
  return sc;
}

int count_kind(const json& alerts, const std::string& kind) {
  int n = 0;
  for (const auto& a : alerts) n += a["kind"] == kind;
  return n;
}

TEST(Verdict, AnInstrumentWithinItsDatasheetRaisesNoAlarm) {
  TempDir dir;
  Goniod g(dir.path, mock_config(lab(kGlossy, "arm_offsets_deg = { receive = 0.3 }\n")));
  auto c = g.unix_conn();
  const auto sc = run(c, kGlossy, "in=45;out=15:75:1");
  EXPECT_EQ(count_kind(sc["alerts"], "sustained_divergence"), 0) << sc["verdict"].dump() << sc["alerts"].dump();
  EXPECT_NE(sc["verdict"]["decision"], "out_of_tolerance") << sc["verdict"].dump();
  EXPECT_NE(sc["verdict"]["decision"], "instrument_out_of_spec") << sc["verdict"].dump();
  EXPECT_EQ(sc["verdict"]["points_used"], 61);
  // Every point carries its budget and its decision; the arm's ±0.5° is in the budget.
  const auto& p = sc["first_points"][0];
  ASSERT_TRUE(p.contains("budget")) << p.dump();
  EXPECT_TRUE(p.contains("decision"));
  EXPECT_EQ(p["u_model"].size(), 5u);
  bool arm = false;
  for (const auto& b : p["budget"])
    if (b["component"] == "receive_arm_deg") {
      arm = true;
      EXPECT_NEAR(b["u"].get<double>(), 0.5 / std::sqrt(3.0), 1e-3);
      EXPECT_EQ(b["distribution"], "rectangular");
    }
  EXPECT_TRUE(arm) << p["budget"].dump();
}

TEST(Verdict, ARedAlbedoTwiceItsToleranceIsFoundAndNamed) {
  TempDir dir;
  Goniod g(dir.path, mock_config(lab("lambert:albedo=400:0.06,500:0.12,600:0.468,700:0.55", "")));
  auto c = g.unix_conn();
  const auto sc = run(c, kPaint, "in=45;out=-30:70:2");
  EXPECT_EQ(sc["verdict"]["decision"], "out_of_tolerance") << sc["verdict"].dump();
  ASSERT_TRUE(sc["verdict"]["cause"].is_object()) << sc["verdict"].dump();
  EXPECT_EQ(sc["verdict"]["cause"]["kind"], "sample");
  EXPECT_EQ(sc["verdict"]["cause"]["parameter"], "lambert.albedo@600") << sc["verdict"].dump();
  EXPECT_NEAR(sc["verdict"]["cause"]["value"].get<double>(), 0.468, 0.01) << sc["verdict"].dump();
  EXPECT_EQ(count_kind(sc["alerts"], "sustained_divergence"), 1) << sc["alerts"].dump();
}

TEST(Verdict, ARoughenedGlossySampleIsTheSampleNotTheWhite) {
  TempDir dir;
  Goniod g(dir.path, mock_config(lab("conductor:alpha=0.055,eta=0.2,k=3.9", "")));
  auto c = g.unix_conn();
  const auto sc = run(c, kGlossy, "in=45;out=15:75:1");
  EXPECT_EQ(sc["verdict"]["decision"], "out_of_tolerance") << sc["verdict"].dump();
  ASSERT_TRUE(sc["verdict"]["cause"].is_object()) << sc["verdict"].dump();
  EXPECT_EQ(sc["verdict"]["cause"]["parameter"], "conductor.alpha") << sc["verdict"].dump();
  EXPECT_NEAR(sc["verdict"]["cause"]["value"].get<double>(), 0.055, 0.002) << sc["verdict"].dump();
}

}  // namespace
}  // namespace gonio::test
