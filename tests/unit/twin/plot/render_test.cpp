// Sphere renders with small test-only BSDFs: lit spheres on a plain background, Lambert
// shading that follows cos(angle to light), equal BSDFs giving equal spheres and different
// ones different spheres, delta lobes reflecting the environment, determinism.
#include "gonio/twin/render.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>
#include <unistd.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/color.hpp"

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

RenderOptions small(int size = 64) {
  RenderOptions o;
  o.size = size;
  o.samples = 4;
  o.threads = 2;
  return o;
}

// The outward normal at the centre of pixel (x, y) of sphere square k, if on the sphere.
std::optional<Vec3> normal_at(const Rendering& r, int x, int y) {
  const double c = 0.5 * r.size;
  const double u = (x % r.size + 0.5 - c) / r.radius, v = (c - (y + 0.5)) / r.radius;
  if (u * u + v * v > 1) return std::nullopt;
  return Vec3{u, v, std::sqrt(1 - u * u - v * v)};
}

double mean_abs_difference(const Rendering& r) {
  double sum = 0;
  int n = 0;
  for (int y = 0; y < r.size; ++y)
    for (int x = 0; x < r.size; ++x) {
      sum += std::abs(r.luminance_at(x, y) - r.luminance_at(x + r.size, y));
      ++n;
    }
  return sum / n;
}

TEST(Render, SpheresAreLitAndTheBackgroundIsPlain) {
  const TestLambert white(kGrid, 0.8);
  const auto r = render_spheres(white, white, small());
  ASSERT_EQ(r.image.width, 128);
  ASSERT_GT(r.image.height, 64);  // caption band below
  for (int k = 0; k < 2; ++k) {
    // corners of each square show no sphere
    for (auto [x, y] : {std::pair{0, 0}, std::pair{63, 0}, std::pair{0, 63}, std::pair{63, 63}})
      EXPECT_EQ(r.image.at(k * 64 + x, y), r.background) << k << " " << x << "," << y;
    // the centre is lit, brighter than the background, and grey (flat albedo)
    const auto c = r.image.at(k * 64 + 32, 32);
    EXPECT_GT(c[1], r.background[1] + 60);
    EXPECT_NEAR(c[0], c[1], 2);
    EXPECT_NEAR(c[2], c[1], 2);
  }
  // Captions: some pixels of the band differ from the background.
  int text = 0;
  for (int y = 64; y < r.image.height; ++y)
    for (int x = 0; x < r.image.width; ++x) text += r.image.at(x, y) != r.background;
  EXPECT_GT(text, 20);
}

TEST(Render, LambertBrightnessFollowsCosineToTheLight) {
  const double albedo = 0.7;
  const TestLambert lambert(kGrid, albedo);
  auto o = small(96);
  o.environment = 0;
  o.light_theta = 50;
  o.light_phi = 30;
  const double th = o.light_theta * kDegToRad, ph = o.light_phi * kDegToRad;
  const Vec3 light{std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)};
  const auto r = render_spheres(lambert, lambert, o);
  int checked = 0, dark = 0;
  double worst = 0;
  for (int y = 0; y < r.size; ++y)
    for (int x = 0; x < r.size; ++x) {
      const auto n = normal_at(r, x, y);
      if (!n || n->z < 0.35) continue;  // stay off the silhouette
      const double expected = albedo * std::max(0.0, dot(*n, light));
      const double got = r.luminance_at(x, y);
      worst = std::max(worst, std::abs(got - expected));
      ++checked;
      if (expected == 0) dark += got == 0;
      // The 8-bit image agrees (exposure 1, no clipping at albedo 0.7).
      if ((x * 7 + y) % 11 == 0) {
        const auto px = r.image.at(x, y);
        EXPECT_NEAR(srgb_decode(px[1] / 255.0), expected, 0.02) << x << "," << y;
      }
    }
  EXPECT_GT(checked, 3000);
  EXPECT_GT(dark, 100);  // the terminator: the far side is black without environment
  // Sub-pixel positions average cos over a pixel (1/radius ≈ 0.02 of the normal).
  EXPECT_LT(worst, 0.03);
}

TEST(Render, EnvironmentAloneLightsALambertSphereUniformly) {
  const TestLambert lambert(kGrid, 0.5);
  auto o = small(48);
  o.light_theta = 180;  // light from behind: only the environment reaches the front
  o.environment = 0.6;
  o.samples = 64;
  const auto r = render_spheres(lambert, lambert, o);
  // White furnace: L = albedo · environment everywhere (estimator exact for cosine
  // sampling of a Lambertian: f cos / pdf = albedo).
  EXPECT_NEAR(r.luminance_at(24, 24), 0.3, 1e-6);
  EXPECT_NEAR(r.luminance_at(30, 15), 0.3, 1e-6);
}

TEST(Render, DifferentBsdfsGiveDifferentSpheres) {
  const TestLambert lambert(kGrid, 0.6);
  const TestPhong phong(kGrid, 0.6, 200);
  const auto r = render_spheres(lambert, phong, small());
  EXPECT_GT(mean_abs_difference(r), 0.05);
  // The glossy sphere's highlight sits where the normal halves light and view.
  auto o = small();
  const double th = o.light_theta * kDegToRad, ph = o.light_phi * kDegToRad;
  const Vec3 h = normalize(Vec3{std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph),
                                std::cos(th)} + Vec3{0, 0, 1});
  int bx = 0, by = 0;
  float best = -1;
  for (int y = 0; y < r.size; ++y)
    for (int x = r.size; x < 2 * r.size; ++x)
      if (r.luminance_at(x, y) > best) {
        best = r.luminance_at(x, y);
        bx = x;
        by = y;
      }
  const auto n = normal_at(r, bx, by);
  ASSERT_TRUE(n.has_value());
  EXPECT_GT(dot(*n, h), std::cos(6 * kDegToRad)) << bx << "," << by;
}

TEST(Render, EqualBsdfsGiveMatchingSpheres) {
  // Two separate objects with the same parameters, glossy so the environment is noisy.
  const TestPhong a(kGrid, 0.5, 40), b(kGrid, 0.5, 40);
  auto o = small();
  o.environment = 0.5;
  const auto r = render_spheres(a, b, o);
  EXPECT_LT(mean_abs_difference(r), 1e-6);
  for (int y = 0; y < r.size; ++y)
    for (int x = 0; x < r.size; ++x)
      ASSERT_EQ(r.image.at(x, y), r.image.at(x + r.size, y)) << x << "," << y;
}

TEST(Render, DeltaLobesReflectTheEnvironment) {
  const TestMirror mirror(kGrid, 0.9);
  auto o = small(48);
  o.environment = 0.5;
  const auto lit = render_spheres(mirror, mirror, o);
  EXPECT_NEAR(lit.luminance_at(24, 24), 0.45, 1e-6);
  o.environment = 0;
  const auto dark = render_spheres(mirror, mirror, o);
  EXPECT_EQ(dark.luminance_at(24, 24), 0.0f);
}

TEST(Render, ColourFollowsTheSpectrum) {
  std::vector<double> reddish;
  for (double nm : kGrid) reddish.push_back(nm > 590 ? 0.8 : 0.05);
  const TestLambert red(kGrid, reddish);
  const TestLambert grey(WavelengthGrid::parse("555"), 0.5);  // one channel: grey
  const auto r = render_spheres(red, grey, small());
  const auto c = r.image.at(32, 32);
  EXPECT_GT(c[0], c[1] + 60);
  EXPECT_GT(c[0], c[2] + 60);
  const auto g = r.image.at(64 + 32, 32);
  EXPECT_NEAR(g[0], g[1], 2);
  EXPECT_NEAR(g[2], g[1], 2);
  // An infrared-only grid still renders (grey from the channel mean).
  const TestLambert ir(WavelengthGrid::parse("1000:1600:100"), 0.5);
  const auto r2 = render_spheres(ir, ir, small());
  EXPECT_GT(r2.luminance_at(32, 32), 0.1f);
}

TEST(Render, IsDeterministicWhateverTheThreadCount) {
  const TestLambert lambert(kGrid, 0.6);
  const TestPhong phong(kGrid, 0.4, 60);
  auto o = small();
  o.environment = 0.3;
  o.threads = 1;
  const auto one = render_spheres(lambert, phong, o);
  o.threads = 3;
  const auto three = render_spheres(lambert, phong, o);
  EXPECT_EQ(one.image.rgb, three.image.rgb);
  EXPECT_EQ(one.luminance, three.luminance);
  o.seed = 2;
  const auto other = render_spheres(lambert, phong, o);
  EXPECT_NE(other.luminance, one.luminance);  // the seed matters (noisy environment)
}

TEST(Render, WritesPngAndValidatesOptions) {
  const TestLambert lambert(kGrid, 0.6);
  const auto r = render_spheres(lambert, lambert, small(32));
  const auto path = std::filesystem::temp_directory_path() /
                    ("gonio-render-" + std::to_string(::getpid()) + ".png");
  write_png(r.image, path.string());
  const Image back = read_png(path.string());
  std::filesystem::remove(path);
  EXPECT_EQ(back.width, r.image.width);
  EXPECT_EQ(back.height, r.image.height);
  EXPECT_EQ(back.rgb, r.image.rgb);

  auto o = small();
  o.size = 4;
  try {
    render_spheres(lambert, lambert, o);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::out_of_range);
    EXPECT_EQ(e.field(), "render.size");
  }
  o = small();
  o.samples = 0;
  EXPECT_THROW(render_spheres(lambert, lambert, o), Error);
  o = small();
  o.exposure = 0;
  EXPECT_THROW(render_spheres(lambert, lambert, o), Error);
  o = small();
  o.environment = -1;
  EXPECT_THROW(render_spheres(lambert, lambert, o), Error);
}

}  // namespace
}  // namespace gonio::twin
