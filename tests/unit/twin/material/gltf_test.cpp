// glTF 2.0 out: the document's structure (an embedded sphere that decodes to what the
// accessors say, the material and its extensions), colours of spectra as linear sRGB, the
// fit recovering a glTF material it is given, and the glossy-paint target (mean ΔE00 ≤ 2 on
// the studio render).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/twin/material.hpp"

namespace gonio::twin {
namespace {

const WavelengthGrid& grid() {
  static const auto g = WavelengthGrid::parse("400:700:10");
  return g;
}

std::size_t decoded_size(const std::string& b64) {
  std::size_t pad = 0;
  while (!b64.empty() && b64[b64.size() - 1 - pad] == '=') ++pad;
  return b64.size() / 4 * 3 - pad;
}

TEST(GltfDocument, SphereAndMaterialAreWhatTheAccessorsSay) {
  material::GltfMaterial m;
  m.base_color = {0.8, 0.2, 0.1};
  m.metallic = 0;
  m.roughness = 0.3;
  m.ior = 1.45;
  m.clearcoat = 0.5;
  m.clearcoat_roughness = 0.1;
  const auto doc = nlohmann::json::parse(material::gltf_document(m, "paint", 8));
  EXPECT_EQ(doc["asset"]["version"], "2.0");
  const auto& buf = doc["buffers"][0];
  const auto uri = buf["uri"].get<std::string>();
  const std::string prefix = "data:application/octet-stream;base64,";
  ASSERT_EQ(uri.rfind(prefix, 0), 0u);
  EXPECT_EQ(decoded_size(uri.substr(prefix.size())), buf["byteLength"].get<std::size_t>());
  const std::size_t vertices = 9 * 17;
  EXPECT_EQ(doc["accessors"][0]["count"], vertices);
  EXPECT_EQ(doc["accessors"][1]["count"], vertices);
  // 8 rings × 16 segments of quads, the two polar rings as triangles.
  EXPECT_EQ(doc["accessors"][2]["count"], 3u * (2 * 8 * 16 - 2 * 16));
  std::size_t views = 0;
  for (const auto& v : doc["bufferViews"]) views += v["byteLength"].get<std::size_t>();
  EXPECT_EQ(views, buf["byteLength"].get<std::size_t>());
  const auto& mat = doc["materials"][0];
  EXPECT_EQ(mat["pbrMetallicRoughness"]["baseColorFactor"], nlohmann::json({0.8, 0.2, 0.1, 1.0}));
  EXPECT_EQ(mat["pbrMetallicRoughness"]["roughnessFactor"], 0.3);
  EXPECT_EQ(mat["extensions"]["KHR_materials_ior"]["ior"], 1.45);
  EXPECT_EQ(mat["extensions"]["KHR_materials_clearcoat"]["clearcoatFactor"], 0.5);
  EXPECT_EQ(mat["extensions"]["KHR_materials_specular"]["specularFactor"], 1.0);
  EXPECT_EQ(doc["extensionsUsed"].size(), 3u);
}

TEST(GltfColor, FlatSpectraAreGreyAndRampsArePartitionOfUnity) {
  const auto m = material::gltf_from_spec("gltf:base_color=0.5,metallic=0,roughness=0.5", grid());
  // 2e-4: the sRGB matrix (IEC 61966-2-1) is given to four decimals.
  for (const double c : m.base_color) EXPECT_NEAR(c, 0.5, 2e-4);
  EXPECT_EQ(material::rgb_spectrum({0.3, 0.3, 0.3}), "0.3");
  // Red ramp: long wavelengths reflect, short ones do not; the colour is reddish.
  const auto red = material::gltf_from_spec(
      "gltf:base_color=" + material::rgb_spectrum({1, 0, 0}) + ",metallic=0", grid());
  EXPECT_GT(red.base_color[0], 0.5);
  EXPECT_LT(red.base_color[2], 0.1);
}

// A glTF material fitted to itself comes back with a colour difference near zero.
TEST(GltfFit, RecoversAGltfMaterial) {
  const auto target = make_bsdf("gltf:base_color=0.6,metallic=0,roughness=0.4", grid());
  material::GltfFitOptions o;
  o.render_check = false;
  const auto r = material::fit_gltf(*target, o);
  EXPECT_LT(r.geometries.mean, 0.05) << r.spec;
  EXPECT_NEAR(r.material.roughness, 0.4, 0.02) << r.spec;
  EXPECT_LT(r.material.metallic, 0.05) << r.spec;
}

// A statistical or dense numerical target: seconds in an optimised build (the ci preset),
// minutes under the sanitizers' unoptimised build, where the cheaper cases of this file run
// the same code.
#ifdef NDEBUG
#define SKIP_UNLESS_OPTIMISED() (void)0
#else
#define SKIP_UNLESS_OPTIMISED() GTEST_SKIP() << "numerical target: run in an optimised build"
#endif

// The target for a glossy paint: mean ΔE00 ≤ 2 on the twin's studio render.
TEST(GltfFit, GlossyPaintWithinTwoOnTheStudioRender) {
  SKIP_UNLESS_OPTIMISED();
  const auto target = make_bsdf("plastic:albedo=400:0.05,500:0.1,600:0.6,700:0.7,alpha=0.08,ior=1.5", grid());
  material::GltfFitOptions o;
  o.check.size = 64;
  o.check.rel_se = 0.02;
  o.check.lighting.environment = EnvironmentKind::studio;
  const auto r = material::fit_gltf(*target, o);
  ASSERT_TRUE(r.studio);
  EXPECT_LE(r.studio->mean, 2.0) << r.spec;
  EXPECT_GT(r.studio->samples, 1000u);
}

}  // namespace
}  // namespace gonio::twin
