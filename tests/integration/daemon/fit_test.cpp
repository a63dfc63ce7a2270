// scan.fit against a real goniod on the mock: the material of a stored scan is fitted through
// the twin, the result is returned and stored with the scan (scan.get lists it, newest
// first), and bad parameters name their field.
#include <gtest/gtest.h>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

constexpr const char* kGlossy = "conductor:alpha=0.08,eta=0.2,k=3.9";

std::int64_t glossy_scan(Conn& c) {
  const auto id = submit(c, "glossy", kGlossy,
                         json{{"grids", {"in=45;out=25:65:2"}}, {"wavelengths", "450,550,650"}});
  const auto sc = wait_state(c, id, {"completed", "failed", "paused"}, 60s);
  EXPECT_EQ(sc["state"], "completed") << sc.dump();
  return id;
}

TEST(ScanFit, RecoversTheMockSamplesRoughnessAndStoresTheFit) {
  TempDir dir;
  MockOptions o;
  o.true_sample = kGlossy;
  o.lab = "full_scale_counts = 1e12\n";  // the specular peak must not saturate the detector
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  const auto id = glossy_scan(c);

  const auto fit = c.call("scan.fit", json{{"scan", id},
                                           {"model", "conductor:alpha=?0.2[0.01,0.5],eta=0.2,k=3.9"},
                                           {"samples", 4096}});
  ASSERT_EQ(fit["scan"], id) << fit.dump();
  EXPECT_EQ(fit["kind"], "fit");
  const auto& result = fit["result"];
  ASSERT_EQ(result["parameters"].size(), 1u) << result.dump();
  const auto& alpha = result["parameters"][0];
  EXPECT_EQ(alpha["name"], "conductor.alpha");
  // Started at 0.2, far from the truth: the fit must find 0.08 (the mock's readings carry
  // detector noise, so allow its uncertainty and a little model noise).
  const double value = alpha["value"].get<double>(), u = alpha["u"].get<double>();
  EXPECT_GT(u, 0);
  EXPECT_NEAR(value, 0.08, std::max(4 * u, 0.004)) << result.dump();
  EXPECT_EQ(result["points"], 21);

  // Stored with the scan, newest first.
  c.call("scan.fit", json{{"scan", id}, {"model", "conductor:alpha=?,eta=0.2,k=3.9"}, {"samples", 2048}});
  const auto sc = c.call("scan.get", json{{"scan", id}});
  ASSERT_EQ(sc["fits"].size(), 2u) << sc.dump();
  EXPECT_EQ(sc["fits"][0]["model"], "conductor:alpha=?,eta=0.2,k=3.9");
  EXPECT_EQ(sc["fits"][1]["model"], "conductor:alpha=?0.2[0.01,0.5],eta=0.2,k=3.9");
  EXPECT_GT(sc["fits"][0]["id"].get<std::int64_t>(), sc["fits"][1]["id"].get<std::int64_t>());
  EXPECT_DOUBLE_EQ(sc["fits"][1]["result"]["parameters"][0]["value"].get<double>(), value);
}

TEST(ScanFit, BadParamsNameTheirField) {
  TempDir dir;
  MockOptions o;
  o.true_sample = kGlossy;
  o.lab = "full_scale_counts = 1e12\n";  // the specular peak must not saturate the detector
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  const auto id = glossy_scan(c);
  struct Case {
    json params;
    int code;
    std::string field;
  };
  const std::vector<Case> cases{
      {json{{"scan", 999}, {"model", "conductor:alpha=?,eta=0.2,k=3.9"}}, -32002, "scan"},
      {json{{"scan", id}, {"model", "conductor:alpha=0.1,eta=0.2,k=3.9"}}, -32602, "model"},
      {json{{"scan", id}, {"model", "conductor:alpha=?,bogus=1"}}, -32602, "model.conductor.bogus"},
      {json{{"scan", id}, {"model", "conductor:alpha=?"}, {"samples", 10}}, -32602, "samples"},
  };
  for (const auto& bc : cases) {
    const auto r = c.request("scan.fit", bc.params);
    ASSERT_TRUE(r.contains("error")) << bc.params.dump() << " -> " << r.dump();
    EXPECT_EQ(r["error"]["code"], bc.code) << r.dump();
    EXPECT_EQ(r["error"]["data"].value("field", std::string()), bc.field) << r.dump();
  }
  // Nothing was stored by the failed calls.
  EXPECT_TRUE(c.call("scan.get", json{{"scan", id}})["fits"].empty());
}

}  // namespace
}  // namespace gonio::test
