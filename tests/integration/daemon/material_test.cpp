// scan.material against a real goniod on the mock: a stored fit written as Mitsuba 3 XML
// (the fitted roughness in a roughconductor) and as glTF 2.0 (a metal, with its ΔE00), and
// what cannot be written refused naming the field: MERL (gonio-twin's only), a lobe Mitsuba
// has no plugin for, a scan without a fit, a fit that does not exist.
#include <gtest/gtest.h>

#include <string>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

constexpr const char* kGlossy = "conductor:alpha=0.08,eta=0.2,k=3.9";

void expect_error(Conn& c, const json& params, int code, const std::string& field) {
  const auto r = c.request("scan.material", params);
  ASSERT_TRUE(r.contains("error")) << params.dump() << " -> " << r.dump();
  EXPECT_EQ(r["error"]["code"], code) << r.dump();
  EXPECT_EQ(r["error"]["data"].value("field", std::string()), field) << r.dump();
}

TEST(ScanMaterial, AStoredFitAsMitsubaAndGltf) {
  TempDir dir;
  MockOptions o;
  o.true_sample = kGlossy;
  o.lab = "full_scale_counts = 1e12\n";  // the specular peak must not saturate the detector
  Goniod g(dir.path, mock_config(o));
  auto c = g.unix_conn();
  const auto id = submit(c, "glossy", kGlossy,
                         json{{"grids", {"in=45;out=25:65:4"}}, {"wavelengths", "450,550,650"}});
  ASSERT_EQ(wait_state(c, id, {"completed", "failed", "paused"}, 60s)["state"], "completed");
  expect_error(c, json{{"scan", id}, {"format", "mitsuba"}}, -32003, "fit");

  const auto fit = c.call("scan.fit", json{{"scan", id}, {"model", "conductor:alpha=?,eta=0.2,k=3.9"},
                                           {"samples", 2048}});
  const auto fit_id = fit["id"].get<std::int64_t>();
  const double alpha = fit["result"]["parameters"][0]["value"].get<double>();

  const auto xml = c.call("scan.material", json{{"scan", id}, {"format", "mitsuba"}});
  EXPECT_EQ(xml["fit"], fit_id);
  EXPECT_EQ(xml["filename"], "scan" + std::to_string(id) + "-fit" + std::to_string(fit_id) + ".xml");
  EXPECT_EQ(xml["media_type"], "application/xml");
  const auto content = xml["content"].get<std::string>();
  EXPECT_NE(content.find(R"(<bsdf type="roughconductor">)"), std::string::npos) << content;
  const auto at = content.find(R"(<float name="alpha" value=")");
  ASSERT_NE(at, std::string::npos) << content;
  EXPECT_NEAR(std::stod(content.substr(at + 27)), alpha, 1e-6 * alpha) << content;
  EXPECT_FALSE(xml["notes"].empty());  // the masking Mitsuba does differently

  const auto gltf = c.call("scan.material", json{{"scan", id}, {"fit", fit_id}, {"format", "gltf"}});
  EXPECT_EQ(gltf["media_type"], "model/gltf+json");
  const auto doc = json::parse(gltf["content"].get<std::string>());
  EXPECT_EQ(doc["asset"]["version"], "2.0");
  EXPECT_GT(doc["materials"][0]["pbrMetallicRoughness"]["metallicFactor"].get<double>(), 0.5) << doc["materials"];
  const auto& de = gltf["gltf"]["delta_e_geometries"];
  EXPECT_GT(de["samples"].get<int>(), 100);
  EXPECT_GE(de["max"].get<double>(), de["mean"].get<double>());

  expect_error(c, json{{"scan", id}, {"format", "merl"}}, -32602, "format");
  expect_error(c, json{{"scan", id}, {"fit", fit_id + 100}, {"format", "gltf"}}, -32002, "fit");
  expect_error(c, json{{"scan", 999}, {"format", "gltf"}}, -32002, "scan");

  // A lobe Mitsuba 3 has no plugin for: refused naming it.
  c.call("scan.fit", json{{"scan", id}, {"model", "oren-nayar:albedo=?,sigma=20"}, {"samples", 1024}});
  expect_error(c, json{{"scan", id}, {"format", "mitsuba"}}, -32008, "fit.oren-nayar");
}

}  // namespace
}  // namespace gonio::test
