// Sphere renders with small test-only BSDFs: lit spheres on a plain background, Lambert
// shading that follows cos(angle to light), white-furnace checks of the control variate and
// of the area light's multiple importance sampling, delta lobes reflecting the environment,
// colour, determinism, the noise target, ΔE00 maps and the composed figure.
#include "gonio/twin/render.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>

#include <gtest/gtest.h>
#include <unistd.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/color.hpp"
#include "gonio/twin/tabulated.hpp"
#include "gonio/twin/virtual_measurement.hpp"

namespace gonio::twin {
namespace {

const WavelengthGrid kGrid = WavelengthGrid::parse("400:700:20");

// Ideal diffuse reflector, albedo per channel; cosine-weighted sampling.
class TestLambert final : public Bsdf {
 public:
  TestLambert(WavelengthGrid grid, std::vector<double> albedo)
      : Bsdf(std::move(grid)), albedo_(std::move(albedo)) {}
  TestLambert(const WavelengthGrid& grid, double albedo)
      : TestLambert(grid, std::vector<double>(grid.size(), albedo)) {}

  void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const override {
    const bool up = wi.z > 0 && wo.z > 0;
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = up ? albedo_[i] * kInvPi : 0.0;
  }
  std::optional<BsdfSample> sample_wi(const Vec3&, double, Vec2 u) const override {
    const double r = std::sqrt(u.x), phi = 2 * kPi * u.y;
    const Vec3 wi{r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0, 1 - u.x))};
    if (wi.z <= 0) return std::nullopt;
    return BsdfSample{wi, wi.z * kInvPi};
  }
  double pdf(const Vec3&, const Vec3& wi) const override {
    return wi.z > 0 ? wi.z * kInvPi : 0.0;
  }
  std::string spec() const override { return "test-lambert"; }

 private:
  std::vector<double> albedo_;
};

// A narrow Phong-like lobe around the mirror direction (not energy-exact; sampling and
// pdf are consistent, which is all the renderer relies on).
class TestPhong final : public Bsdf {
 public:
  TestPhong(const WavelengthGrid& grid, double ks, double exponent)
      : Bsdf(grid), ks_(ks), n_(exponent) {}

  void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const override {
    const double c = wi.z > 0 && wo.z > 0 ? std::max(0.0, dot(wi, mirror(wo))) : 0.0;
    const double f = ks_ * (n_ + 2) / (2 * kPi) * std::pow(c, n_);
    std::fill(out.begin(), out.end(), f);
  }
  std::optional<BsdfSample> sample_wi(const Vec3& wo, double, Vec2 u) const override {
    const double cos_a = std::pow(u.x, 1 / (n_ + 1));
    const Vec3 local = spherical(std::acos(cos_a), 2 * kPi * u.y);
    const Vec3 wi = Frame::from_normal(mirror(wo)).to_world(local);
    if (wi.z <= 0) return std::nullopt;
    return BsdfSample{wi, pdf(wo, wi)};
  }
  double pdf(const Vec3& wo, const Vec3& wi) const override {
    if (wi.z <= 0) return 0;
    return (n_ + 1) / (2 * kPi) * std::pow(std::max(0.0, dot(wi, mirror(wo))), n_);
  }
  std::string spec() const override { return "test-phong"; }

 private:
  static Vec3 mirror(const Vec3& wo) { return {-wo.x, -wo.y, wo.z}; }
  double ks_, n_;
};

// An ideal mirror: nothing but a delta lobe.
class TestMirror final : public Bsdf {
 public:
  TestMirror(const WavelengthGrid& grid, double r) : Bsdf(grid), r_(r) {}
  void eval(const Vec3&, const Vec3&, std::span<double> out) const override {
    std::fill(out.begin(), out.end(), 0.0);
  }
  std::optional<BsdfSample> sample_wi(const Vec3&, double, Vec2) const override {
    return std::nullopt;
  }
  double pdf(const Vec3&, const Vec3&) const override { return 0; }
  void delta_lobes(const Vec3& wo, std::vector<DeltaLobe>& out) const override {
    out.assign(1, DeltaLobe{{-wo.x, -wo.y, wo.z}, std::vector<double>(channels(), r_)});
  }
  bool has_delta() const noexcept override { return true; }
  std::string spec() const override { return "test-mirror"; }

 private:
  double r_;
};

// Heavy cases (dense tables, many samples) run in optimised builds only.
#ifdef NDEBUG
#define SKIP_UNLESS_OPTIMISED() (void)0
#else
#define SKIP_UNLESS_OPTIMISED() GTEST_SKIP() << "many samples: run in an optimised build"
#endif

RenderOptions small(int size = 64) {
  RenderOptions o;
  o.size = size;
  o.threads = 2;
  o.lighting.light_size = 0;
  o.lighting.environment = EnvironmentKind::none;
  return o;
}

// The outward normal at the centre of pixel (x, y), if on the sphere.
std::optional<Vec3> normal_at(const SphereImage& r, int x, int y) {
  const double c = 0.5 * r.size;
  const double u = (x + 0.5 - c) / r.radius, v = (c - (y + 0.5)) / r.radius;
  if (u * u + v * v > 1) return std::nullopt;
  return Vec3{u, v, std::sqrt(1 - u * u - v * v)};
}

Vec3 light_of(const RenderOptions& o) {
  const double th = o.lighting.light_theta * kDegToRad, ph = o.lighting.light_phi * kDegToRad;
  return {std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)};
}

TEST(Render, SpheresAreLitAndTheBackgroundIsPlain) {
  const TestLambert white(kGrid, 0.8);
  auto o = small();
  o.lighting.environment = EnvironmentKind::uniform;
  const auto r = render_comparison({&white, &white}, {"left", "right"}, o);
  ASSERT_EQ(r.spheres.size(), 2u);
  ASSERT_EQ(r.maps.size(), 1u);
  ASSERT_GE(r.image.width, 3 * 64);  // two spheres, one map, the scale bar
  ASSERT_GT(r.image.height, 64);     // caption band below
  for (int k = 0; k < 2; ++k) {
    for (auto [x, y] : {std::pair{0, 0}, std::pair{63, 0}, std::pair{0, 63}, std::pair{63, 63}})
      EXPECT_EQ(r.image.at(k * 64 + x, y), kRenderBackground) << k << " " << x << "," << y;
    const auto c = r.image.at(k * 64 + 32, 32);
    EXPECT_GT(c[1], kRenderBackground[1] + 60);
    EXPECT_NEAR(c[0], c[1], 2);
    EXPECT_NEAR(c[2], c[1], 2);
  }
  EXPECT_EQ(r.maps[0].stats.max, 0.0);  // the same BSDF, the same random numbers
  int text = 0;
  for (int y = 64; y < r.image.height; ++y)
    for (int x = 0; x < r.image.width; ++x) text += r.image.at(x, y) != kRenderBackground;
  EXPECT_GT(text, 20);
}

TEST(Render, LambertBrightnessFollowsCosineToTheLight) {
  const double albedo = 0.7;
  const TestLambert lambert(kGrid, albedo);
  auto o = small(96);
  o.lighting.light_theta = 50;
  o.lighting.light_phi = 30;
  const Vec3 light = light_of(o);
  const auto r = render_sphere(lambert, o);
  int checked = 0, dark = 0;
  for (int y = 0; y < r.size; ++y)
    for (int x = 0; x < r.size; ++x) {
      const auto n = normal_at(r, x, y);
      if (!n || r.coverage[r.index(x, y)] < 1) continue;
      const double expected = albedo * std::max(0.0, dot(*n, light));
      ASSERT_NEAR(r.luminance_at(x, y), expected, 1e-9) << x << "," << y;
      ++checked;
      dark += expected == 0;
      if ((x * 7 + y) % 11 == 0) {
        EXPECT_NEAR(display_rgb(r.xyz[r.index(x, y)], o).g, expected, 0.01) << x << "," << y;
      }
    }
  EXPECT_GT(checked, 5000);
  EXPECT_GT(dark, 100);  // the far side is black without an environment
  EXPECT_EQ(r.noise.mean_samples, 0);  // nothing stochastic in this scene
}

TEST(Render, UniformEnvironmentIsExactThroughTheControlVariate) {
  // White furnace: L = albedo · level everywhere; the control variate's expectation holds
  // the whole integral and every sample's residual is zero, Lambertian or glossy.
  const TestLambert lambert(kGrid, 0.5);
  const TestPhong phong(kGrid, 0.6, 80);
  auto o = small(48);
  o.lighting.light_theta = 180;  // behind the sphere: only the environment lights the front
  o.lighting.environment = EnvironmentKind::uniform;
  o.lighting.environment_level = 0.6;
  const auto r = render_sphere(lambert, o);
  EXPECT_NEAR(r.luminance_at(24, 24), 0.3, 1e-9);
  EXPECT_NEAR(r.luminance_at(30, 15), 0.3, 1e-9);
  EXPECT_EQ(r.noise.max_rel_se, 0);
  const auto g = render_sphere(phong, o);
  EXPECT_EQ(g.noise.max_rel_se, 0);
  EXPECT_NEAR(g.noise.mean_samples, o.min_samples, 1e-9);
}

TEST(Render, AreaLightMatchesAPointLightOnADiffuser) {
  SKIP_UNLESS_OPTIMISED();
  // A small disc of irradiance 1 lights a Lambertian sphere like a point light (cos θ
  // averaged over the disc differs by < 1e-3 away from the terminator); the estimate goes
  // through emitter sampling and BSDF sampling weighted by the power heuristic.
  const TestLambert lambert(kGrid, 0.8);
  auto o = small(48);
  o.lighting.light_size = 3;
  o.rel_se = 0.005;
  const Vec3 light = light_of(o);
  const auto r = render_sphere(lambert, o);
  int checked = 0;
  for (int y = 0; y < r.size; ++y)
    for (int x = 0; x < r.size; ++x) {
      const auto n = normal_at(r, x, y);
      if (!n || r.coverage[r.index(x, y)] < 1 || dot(*n, light) < 0.2) continue;
      const double expected = 0.8 * dot(*n, light);
      EXPECT_NEAR(r.luminance_at(x, y), expected, 4 * 0.005 * expected + 1e-3) << x << "," << y;
      ++checked;
    }
  EXPECT_GT(checked, 500);
}

TEST(Render, GlossySpheresReachTheNoiseTargetOrSaySo) {
  SKIP_UNLESS_OPTIMISED();
  const TestPhong phong(kGrid, 0.7, 150);
  for (auto env : {EnvironmentKind::sky, EnvironmentKind::studio}) {
    auto o = small(40);
    o.lighting.environment = env;
    o.lighting.light_size = 2;
    o.rel_se = 0.02;
    o.max_samples = 1024;
    const auto r = render_sphere(phong, o);
    EXPECT_GT(r.noise.lit_pixels, 300u) << to_text(env);
    EXPECT_GE(r.noise.mean_samples, o.min_samples);
    // Every lit pixel either met the target or spent the whole budget (a softbox's edge
    // inside a glossy lobe converges slowest); the smooth sky converges everywhere.
    for (std::size_t i = 0; i < r.xyz.size(); ++i) {
      if (r.coverage[i] >= 1 && r.xyz[i].y >= kLitFloor && r.rel_se[i] > o.rel_se) {
        ASSERT_EQ(r.samples[i], static_cast<std::uint32_t>(o.max_samples)) << i;
      }
    }
    if (env == EnvironmentKind::sky) {
      EXPECT_GE(r.noise.converged_fraction, 0.99);
      EXPECT_LE(r.noise.p95_rel_se, o.rel_se + 1e-12);
    }
  }
}

TEST(Render, ReportedNoiseIsTheNoiseBetweenSeeds) {
  SKIP_UNLESS_OPTIMISED();
  // Two renders with different seeds differ per pixel by their own noise: pooled over the
  // lit pixels, that difference must agree with the standard errors the renders report, and
  // the actual relative noise must be at the target — the adaptive stop may not fool itself.
  const TestPhong phong(kGrid, 0.7, 150);
  auto o = small(64);
  o.lighting.environment = EnvironmentKind::sky;
  o.lighting.light_size = 2;
  o.rel_se = 0.02;
  const auto a = render_sphere(phong, o);
  o.seed = 7;
  const auto b = render_sphere(phong, o);
  double d2 = 0, se2 = 0, rel2 = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < a.xyz.size(); ++i) {
    if (a.coverage[i] < 1 || a.xyz[i].y < kLitFloor || b.xyz[i].y < kLitFloor) continue;
    const double d = a.xyz[i].y - b.xyz[i].y;
    const double sa = a.rel_se[i] * a.xyz[i].y, sb = b.rel_se[i] * b.xyz[i].y;
    d2 += d * d;
    se2 += sa * sa + sb * sb;
    const double y = 0.5 * (a.xyz[i].y + b.xyz[i].y);
    rel2 += d * d / (2 * y * y);
    ++n;
  }
  ASSERT_GT(n, 1500u);
  const double actual = std::sqrt(rel2 / static_cast<double>(n));
  std::cout << "actual/reported noise " << std::sqrt(d2 / se2) << ", actual rel. s.e. " << actual << "\n";
  EXPECT_LT(std::sqrt(d2 / se2), 1.25);
  EXPECT_LT(actual, o.rel_se);
}

TEST(Render, DeltaLobesReflectTheEnvironment) {
  const TestMirror mirror(kGrid, 0.9);
  auto o = small(48);
  o.lighting.environment = EnvironmentKind::uniform;
  o.lighting.environment_level = 0.5;
  const auto lit = render_sphere(mirror, o);
  EXPECT_NEAR(lit.luminance_at(24, 24), 0.45, 1e-9);
  o.lighting.environment = EnvironmentKind::none;
  const auto dark = render_sphere(mirror, o);
  EXPECT_EQ(dark.luminance_at(24, 24), 0.0);
}

TEST(Render, ColorFollowsTheSpectrum) {
  std::vector<double> reddish;
  for (double nm : kGrid) reddish.push_back(nm > 590 ? 0.8 : 0.05);
  const TestLambert red(kGrid, reddish);
  auto o = small();
  o.lighting.light_theta = 0;
  const auto r = render_sphere(red, o);
  const auto c = display_rgb(r.xyz[r.index(32, 32)], o);
  EXPECT_GT(c.r, 4 * c.g);
  EXPECT_GT(c.r, 4 * c.b);
  o.color = false;  // luminance alone: neutral
  const auto grey = display_rgb(render_sphere(red, o).xyz[r.index(32, 32)], o);
  EXPECT_NEAR(grey.r, grey.g, 1e-3);
  EXPECT_NEAR(grey.b, grey.g, 1e-3);
  o.color = true;
  const TestLambert one(WavelengthGrid::parse("555"), 0.5);  // one channel: grey
  const auto g = display_rgb(render_sphere(one, o).xyz[r.index(32, 32)], o);
  EXPECT_NEAR(g.r, g.g, 1e-3);
  EXPECT_NEAR(g.b, g.g, 1e-3);
  // An infrared-only grid still renders (grey from the channel mean).
  const TestLambert ir(WavelengthGrid::parse("1000:1600:100"), 0.5);
  EXPECT_NEAR(render_sphere(ir, o).luminance_at(32, 32), 0.5, 0.01);
}

TEST(Render, IsDeterministicWhateverTheThreadCount) {
  SKIP_UNLESS_OPTIMISED();
  const TestPhong phong(kGrid, 0.4, 60);
  auto o = small(48);
  o.lighting.environment = EnvironmentKind::sky;
  o.lighting.light_size = 3;
  o.rel_se = 0.03;
  o.threads = 1;
  const auto one = render_sphere(phong, o);
  o.threads = 3;
  const auto three = render_sphere(phong, o);
  ASSERT_EQ(one.xyz.size(), three.xyz.size());
  for (std::size_t i = 0; i < one.xyz.size(); ++i) {
    ASSERT_EQ(one.xyz[i].y, three.xyz[i].y) << i;
    ASSERT_EQ(one.samples[i], three.samples[i]) << i;
  }
  o.seed = 2;
  const auto other = render_sphere(phong, o);
  int differ = 0;
  for (std::size_t i = 0; i < one.xyz.size(); ++i) differ += one.xyz[i].y != other.xyz[i].y;
  EXPECT_GT(differ, 100);  // the seed matters
}

TEST(Render, ValidatesOptionsNamingTheField) {
  const TestLambert lambert(kGrid, 0.6);
  const auto field_of = [&](RenderOptions o) -> std::string {
    try {
      render_sphere(lambert, o);
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), Errc::out_of_range);
      return e.field();
    }
    return "";
  };
  auto o = small();
  o.size = 4;
  EXPECT_EQ(field_of(o), "render.size");
  o = small();
  o.rel_se = 0;
  EXPECT_EQ(field_of(o), "render.rel_se");
  o = small();
  o.lighting.light_size = 60;
  EXPECT_EQ(field_of(o), "render.light_size");
  o = small();
  o.max_samples = 8;
  EXPECT_EQ(field_of(o), "render.max_samples");
  o = small();
  o.exposure = 0;
  EXPECT_EQ(field_of(o), "render.exposure");
  o = small();
  o.lighting.environment_level = -1;
  EXPECT_EQ(field_of(o), "render.environment_level");
}

TEST(Render, DeltaEMapsMeasureTheDifference) {
  const TestLambert a(kGrid, 0.5), b(kGrid, 0.55);
  auto o = small(48);
  o.lighting.environment = EnvironmentKind::uniform;
  const auto ra = render_sphere(a, o), rb = render_sphere(b, o);
  const auto same = delta_e_map(ra, ra, o);
  EXPECT_EQ(same.stats.max, 0);
  EXPECT_GT(same.stats.pixels, 1000u);
  const auto m = delta_e_map(ra, rb, o);
  EXPECT_GT(m.stats.mean, 0.5);
  EXPECT_LE(m.stats.mean, m.stats.p95 + 1e-12);
  EXPECT_LE(m.stats.p95, m.stats.max);
  // The centre pixel by hand: CIEDE2000 of the two displayed colours.
  const std::size_t c = ra.index(24, 24);
  EXPECT_NEAR(m.delta_e[c],
              delta_e2000(display_lab(display_rgb(ra.xyz[c], o)), display_lab(display_rgb(rb.xyz[c], o))),
              1e-4);
  // The colour scale gets lighter from 0 to 1, and the figure has a place for everything.
  double last = -1;
  for (int k = 0; k <= 20; ++k) {
    const auto col = delta_e_color(k / 20.0);
    const double y = 0.2126 * srgb_decode(col[0] / 255.0) + 0.7152 * srgb_decode(col[1] / 255.0) +
                     0.0722 * srgb_decode(col[2] / 255.0);
    EXPECT_GT(y, last) << k;
    last = y;
  }
  Panels p;
  p.spheres = {&ra, &rb, &rb};
  p.sphere_captions = {"a", "b", "c"};
  p.maps = {&m, &m};
  p.map_captions = {"ΔE00 b\nmean", "ΔE00 c\nmean"};
  const Image img = compose_panels(p, o);
  EXPECT_GE(img.width, 5 * 48);
  const auto hot = img.at(3 * 48 + 24, 24);
  EXPECT_NE(hot, kRenderBackground);
  p.map_captions.pop_back();
  EXPECT_THROW(compose_panels(p, o), Error);
}

// ---- golden image -----------------------------------------------------------------------------
// A small render of an analytic conductor and of its table, stored as little-endian float32
// X, Y, Z per pixel (both spheres). Regenerate after an intended change with
// GONIO_UPDATE_GOLDEN=1 and say why in the commit.
std::vector<float> golden_render() {
  const auto grid = WavelengthGrid::parse("400:700:20");
  const auto model = make_bsdf("conductor:alpha=0.15,eta=0.2,k=3.9", grid);
  TabulatedParts parts;
  parts.brdf = tabulate_specular(*model, specular_measurement_grid(5, 1, 15));
  const TabulatedBsdf table(grid, std::move(parts), "table");
  RenderOptions o;
  o.size = 40;
  o.threads = 2;
  o.rel_se = 0.01;
  o.lighting.light_size = 4;
  std::vector<float> out;
  for (const Bsdf* b : {static_cast<const Bsdf*>(model.get()), static_cast<const Bsdf*>(&table)}) {
    const auto r = render_sphere(*b, o);
    for (const auto& c : r.xyz)
      for (double v : {c.x, c.y, c.z}) out.push_back(static_cast<float>(v));
  }
  return out;
}

TEST(Render, MatchesTheGoldenImage) {
  SKIP_UNLESS_OPTIMISED();
  const std::filesystem::path path =
      std::filesystem::path(GONIO_SOURCE_DIR) / "tests/unit/twin/render/data/render_golden_40.f32";
  const auto got = golden_render();
  if (std::getenv("GONIO_UPDATE_GOLDEN") != nullptr) {
    std::ofstream f(path, std::ios::binary);
    f.write(reinterpret_cast<const char*>(got.data()),
            static_cast<std::streamsize>(got.size() * sizeof(float)));
    GTEST_SKIP() << "wrote " << path;
  }
  std::ifstream f(path, std::ios::binary);
  ASSERT_TRUE(f) << path;
  std::vector<float> want(got.size());
  f.read(reinterpret_cast<char*>(want.data()), static_cast<std::streamsize>(want.size() * sizeof(float)));
  ASSERT_EQ(f.gcount(), static_cast<std::streamsize>(want.size() * sizeof(float)));
  // Per pixel: within 5 standard errors (1 % each) plus a floor for the dark backdrop; a
  // different libm may move the adaptive stopping, not the expectation. On average far
  // tighter.
  double sum = 0, sum_ref = 0;
  int bad = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    const double d = std::abs(got[i] - want[i]);
    sum += d;
    sum_ref += std::abs(want[i]);
    if (d > 0.05 * std::abs(want[i]) + 2e-3) ++bad;
  }
  EXPECT_EQ(bad, 0);
  EXPECT_LT(sum / sum_ref, 0.004);
}

// The same BSDF twice — the model and a dense table of it — must look the same: what the
// render shows between true and measured is then the instrument, not the table.
TEST(Render, TrueAndDenseTableOfTheSameBsdfLookTheSame) {
  SKIP_UNLESS_OPTIMISED();
  const auto grid = WavelengthGrid::parse("400:700:20");
  const auto model = make_bsdf("conductor:alpha=0.05,eta=0.2,k=3.9", grid);
  TabulatedParts parts;
  parts.brdf = tabulate_specular(*model, specular_measurement_grid(2.5, 0.25, 7.5));
  const TabulatedBsdf table(grid, std::move(parts), "dense table");
  RenderOptions o;  // the default scene: sky and a 2° key light
  o.size = 72;
  o.threads = 2;
  const auto r = render_comparison({model.get(), &table}, {"true", "table"}, o);
  const auto& m = r.maps[0];
  std::size_t below = 0, n = 0;
  for (std::size_t i = 0; i < m.delta_e.size(); ++i) {
    if (m.coverage[i] < 1) continue;
    ++n;
    below += m.delta_e[i] < 1;
  }
  ASSERT_GT(n, 3000u);
  // "Almost everywhere": the renders' own noise (1 % each) alone gives a mean ΔE00 of about
  // 0.3 here, and the table's last θ nodes stop at 85°.
  EXPECT_GE(static_cast<double>(below) / static_cast<double>(n), 0.98)
      << "mean " << m.stats.mean << " p95 " << m.stats.p95 << " max " << m.stats.max;
  EXPECT_LT(m.stats.mean, m.stats.noise_mean + 0.15) << "noise alone " << m.stats.noise_mean;
  EXPECT_LT(m.stats.p95, 1.0);
}

}  // namespace
}  // namespace gonio::twin
