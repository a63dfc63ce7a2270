// A real renderer reads the exported glTF: gonio-twin material writes the fitted glTF sphere,
// Debian's Blender imports it headless and renders it with Cycles under a fixed light
// (blender_render.py), and the picture is compared with the twin's render of the same glTF
// material (its `gltf` model, the specification's reference BRDF) in the same scene.
//
// The bound, mean ΔE00 ≤ 3 over the pixels fully inside the silhouette: the two renderers
// are given the same material but do not evaluate the same BRDF. Blender's importer maps
// glTF onto the Principled BSDF, whose diffuse lobe is Disney's (Burley 2012: retro-
// reflection at grazing angles, brighter or darker than Lambert's by up to ~±25 % with
// roughness), whose specular lobe has the height-correlated masking where glTF's reference has
// the separable one, and whose Fresnel differs from Schlick's near grazing; and each render
// carries its own noise (Cycles at 128 samples per pixel; the twin at 1 % per pixel). A
// mismatch of convention — the scene's units, axes, colour space, a lost extension — shows
// as a difference of 10 or more, which the bound rejects: with the key light mirrored in
// Blender's scene alone (azimuth + 180°) the paint differs by 16.4 and the gold by 11.2;
// as written they differ by about 1 (twin/material.md).
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/test/command.hpp"
#include "gonio/test/temp_dir.hpp"
#include "gonio/twin/render.hpp"

namespace {

namespace fs = std::filesystem;
using namespace gonio::twin;

gonio::test::CommandRun run(const std::string& cmd) { return gonio::test::run_command(cmd + " 2>&1"); }

constexpr int kSize = 64;
constexpr double kLightTheta = 45, kLightPhi = 135, kEnvironment = 0.25;
constexpr double kBound = 3.0;

RenderOptions scene() {
  RenderOptions o;
  o.size = kSize;
  o.rel_se = 0.01;
  o.lighting.light_theta = kLightTheta;
  o.lighting.light_phi = kLightPhi;
  o.lighting.light_size = 0;  // a point light: Blender's sun of angle 0
  o.lighting.environment = EnvironmentKind::uniform;
  o.lighting.environment_level = kEnvironment;
  return o;
}

std::string blender_cmd(const std::string& gltf, const std::string& out, double radius) {
  std::ostringstream c;
  c << "blender -b --factory-startup --python " << GONIO_SOURCE_DIR
    << "/tests/integration/twin/blender_render.py -- " << gltf << ' ' << out << ' ' << kSize << ' '
    << radius << ' ' << kLightTheta << ' ' << kLightPhi << ' ' << kEnvironment << " 128";
  return c.str();
}

struct Compared {
  double mean = 0, max = 0;
  std::size_t pixels = 0;
};

// Blender's pixels (linear Rec.709, row 0 at the top) and the twin's sphere of the same glTF.
struct Rendered {
  std::vector<Rgb> blender;
  SphereImage twin;
};

Rendered render_both(const std::string& spec, const gonio::test::TempDir& dir) {
  const auto gltf = (dir.path() / "material.gltf").string();
  const auto exported = run(std::string(GONIO_BIN_DIR) + "/gonio-twin material --format gltf --no-render --json --bsdf '" +
                            spec + "' --output " + gltf);
  EXPECT_EQ(exported.code, 0) << exported.out;
  const auto report = nlohmann::json::parse(exported.out.substr(exported.out.find('{')));
  const auto fitted = report["gltf"]["spec"].get<std::string>();

  Rendered r;
  const auto model = make_bsdf(fitted, gonio::WavelengthGrid::parse("400:700:10"));
  r.twin = render_sphere(*model, scene());
  const auto pixels = (dir.path() / "blender.txt").string();
  const auto blender = run(blender_cmd(gltf, pixels, r.twin.radius));
  EXPECT_EQ(blender.code, 0) << blender.out;
  std::ifstream in(pixels);
  r.blender.resize(static_cast<std::size_t>(kSize * kSize));
  for (auto& b : r.blender) in >> b.r >> b.g >> b.b;
  EXPECT_TRUE(in.good()) << "short pixel file " << pixels;
  return r;
}

Compared compare(const std::vector<Rgb>& blender, const SphereImage& twin) {
  const auto options = scene();
  Compared c;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const auto i = twin.index(x, y);
      const double dx = x + 0.5 - kSize / 2.0, dy = y + 0.5 - kSize / 2.0;
      // Inside the silhouette of both: the mesh's polygons and the exact sphere differ at the rim.
      if (twin.coverage[i] < 1 || std::hypot(dx, dy) > 0.95 * twin.radius) continue;
      const auto& b = blender[i];
      const Rgb shown{std::clamp(b.r, 0.0, 1.0), std::clamp(b.g, 0.0, 1.0), std::clamp(b.b, 0.0, 1.0)};
      const double de = delta_e2000(display_lab(shown), display_lab(display_rgb(twin.xyz[i], options)));
      c.mean += de;
      c.max = std::max(c.max, de);
      ++c.pixels;
    }
  if (c.pixels > 0) c.mean /= static_cast<double>(c.pixels);
  return c;
}

}  // namespace

// Each material as Blender renders it against the twin's render of the same glTF, and — so
// that the comparison is seen to tell materials apart — Blender's paint against the twin's
// gold, which must differ by far more than the bound.
TEST(Blender, RendersTheExportedGltfAsTheTwinDoes) {
  if (run("blender --version").code != 0)
    FAIL() << "Debian's blender is not installed (.ci/bootstrap --test installs it)";
  std::vector<Rendered> renders;
  for (const char* spec : {"plastic:albedo=400:0.05,500:0.1,600:0.6,700:0.7,alpha=0.08,ior=1.5",
                           "conductor:alpha=0.15,eta=400:1.5,700:0.2,k=400:1.9,700:3.6",
                           // the real table's fit (twin/fitting.md, "A table nobody here made")
                           "plastic:albedo=0.217,alpha=0.268,ior=1.52"}) {
    gonio::test::TempDir dir("blender");
    renders.push_back(render_both(spec, dir));
    const auto c = compare(renders.back().blender, renders.back().twin);
    EXPECT_GT(c.pixels, 2000u) << spec;
    EXPECT_LE(c.mean, kBound) << spec << " (max " << c.max << ")";
    std::printf("[ blender  ] %s: mean ΔE00 %.2f, max %.2f over %zu pixels\n", spec, c.mean, c.max, c.pixels);
  }
  const auto cross = compare(renders[0].blender, renders[1].twin);
  EXPECT_GT(cross.mean, 4 * kBound);
  std::printf("[ blender  ] Blender's paint against the twin's gold: mean ΔE00 %.2f\n", cross.mean);
}
