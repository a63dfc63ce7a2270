// The microfacet building blocks on their own: normalisation of D, the weak white furnace
// (Heitz 2014 §3.3: ∫ D(h) G1(wo) / (4 |cos θo|) dωi = 1 over the whole sphere of
// wi = reflect(wo, h), i.e. Fresnel = 1 and nothing lost to a second bounce counted),
// visible-normal sampling against its density, the shared reflection lobe, and the Fresnel
// formulas' known values.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>

// Private headers of the bsdf family: the test exercises them directly.
#include "gonio/twin/detail/bsdf/fresnel.hpp"
#include "gonio/twin/detail/bsdf/microfacet.hpp"
#include "gonio/twin/detail/bsdf/sampling.hpp"
#include "stats.hpp"

namespace gonio::twin {
namespace {

using bsdf::Distribution;
using bsdf::Microfacet;
using test::dir_deg;

// ∫ D(m) G1(wo) max(0, wo·m) / cos θo dm over the hemisphere of m, by the midpoint rule in
// (v, φ) with tan θm = α v/(1 − v): the substitution follows the lobe for any α.
double furnace_in_normal_space(const Microfacet& mf, const Vec3& wo) {
  const int nv = 1500, nphi = 96;
  double sum = 0;
  for (int i = 0; i < nv; ++i) {
    const double v = (i + 0.5) / nv;
    const double s = v / (1 - v);
    const double theta = std::atan(mf.alpha * s);
    const double dtheta_dv = mf.alpha / (1 + mf.alpha * mf.alpha * s * s) / ((1 - v) * (1 - v));
    for (int j = 0; j < nphi; ++j) {
      const Vec3 m = spherical(theta, 2 * kPi * (j + 0.5) / nphi);
      sum += mf.D(m) * std::max(0.0, dot(wo, m)) * std::sin(theta) * dtheta_dv;
    }
  }
  return sum / nv * 2 * kPi / nphi * mf.G1(wo) / wo.z;
}

// The same integral over directions wi of the whole sphere, h = (wi + wo)/|wi + wo|,
// with the Jacobian dωh/dωi = 1/(4 wo·h): a plain grid in (cos θi, φi), for wide lobes.
double furnace_in_direction_space(const Microfacet& mf, const Vec3& wo) {
  const int nz = 600, nphi = 200;
  double sum = 0;
  for (int i = 0; i < nz; ++i) {
    const double z = -1 + 2 * (i + 0.5) / nz;
    const double r = std::sqrt(1 - z * z);
    for (int j = 0; j < nphi; ++j) {
      const double phi = 2 * kPi * (j + 0.5) / nphi;
      const Vec3 wi{r * std::cos(phi), r * std::sin(phi), z};
      const Vec3 sum_dir = wi + wo;
      if (length(sum_dir) < 1e-12) continue;
      sum += mf.D(normalize(sum_dir));
    }
  }
  return sum * (2.0 / nz) * (2 * kPi / nphi) * mf.G1(wo) / (4 * wo.z);
}

TEST(Microfacet, WeakWhiteFurnaceInNormalSpace) {
  for (auto d : {Distribution::ggx, Distribution::beckmann})
    for (double alpha : {0.001, 0.01, 0.1, 0.5, 1.0})
      for (double t : {0.0, 30.0, 60.0, 80.0, 89.0}) {
        const Microfacet mf{d, alpha};
        // GGX's heavy tails converge slowly at grazing wo for large α: looser there.
        const double tol = (d == Distribution::ggx && alpha >= 0.5 && t >= 80) ? 5e-3 : 1e-3;
        EXPECT_NEAR(furnace_in_normal_space(mf, dir_deg(t, 25)), 1.0, tol)
            << (d == Distribution::ggx ? "ggx" : "beckmann") << " α=" << alpha << " θo=" << t;
      }
}

TEST(Microfacet, WeakWhiteFurnaceInDirectionSpace) {
  for (auto d : {Distribution::ggx, Distribution::beckmann})
    for (double alpha : {0.3, 0.6, 1.0})
      for (double t : {0.0, 45.0, 75.0}) {
        const Microfacet mf{d, alpha};
        EXPECT_NEAR(furnace_in_direction_space(mf, dir_deg(t, 0)), 1.0, 3e-3)
            << (d == Distribution::ggx ? "ggx" : "beckmann") << " α=" << alpha << " θo=" << t;
      }
}

// Visible normals drawn by sample_visible follow visible_pdf: chi-square over the
// hemisphere of m.
class VisibleNormalPdf final : public Bsdf {
 public:
  explicit VisibleNormalPdf(Microfacet mf) : Bsdf(WavelengthGrid::parse("550")), mf_(mf) {}
  void eval(const Vec3&, const Vec3&, std::span<double> out) const override { out[0] = 0; }
  std::optional<BsdfSample> sample_wi(const Vec3& wo, double, Vec2 u) const override {
    const Vec3 m = mf_.sample_visible(wo, u);
    return BsdfSample{m, mf_.visible_pdf(wo, m)};
  }
  double pdf(const Vec3& wo, const Vec3& m) const override { return mf_.visible_pdf(wo, m); }
  std::string spec() const override { return "visible-normals"; }

 private:
  Microfacet mf_;
};

TEST(Microfacet, VisibleNormalSamplingMatchesDensity) {
  int k = 0;
  for (auto d : {Distribution::ggx, Distribution::beckmann})
    for (double alpha : {0.002, 0.1, 0.8})
      for (double t : {0.0, 50.0, 88.0}) {
        const VisibleNormalPdf b(Microfacet{d, alpha});
        // Narrow lobes: bins around the normal; wide ones: (cos θ, φ) bins, whose edge at
        // cos θ = 0 matches the density's cut at the horizon.
        const auto map = alpha < 0.5 ? test::axis_map({0, 0, 1}, 2 * alpha) : test::cos_phi_map();
        const auto r = test::chi2_test(b, dir_deg(t, 70), map, 50000,
                                       100 + static_cast<std::uint64_t>(k++));
        EXPECT_GT(r.p_value, 1e-4) << "α=" << alpha << " θ=" << t << " chi2=" << r.statistic
                                   << " dof=" << r.dof << " " << r.worst;
        EXPECT_NEAR(r.pdf_integral, 1.0, 2e-3) << "α=" << alpha << " θ=" << t;
      }
}

TEST(Microfacet, SmithLambdaLimits) {
  for (auto d : {Distribution::ggx, Distribution::beckmann}) {
    const Microfacet mf{d, 0.3};
    EXPECT_EQ(mf.lambda({0, 0, 1}), 0.0);
    EXPECT_EQ(mf.G1({1, 0, 0}), 0.0);  // grazing: fully masked
    EXPECT_LT(mf.G1(dir_deg(80)), mf.G1(dir_deg(40)));
    EXPECT_NEAR(mf.G2(dir_deg(0), dir_deg(0)), 1.0, 1e-15);
  }
}

// The reflection lobe conductor and coat share: two-sided, its samples carry the density
// reflection_pdf gives, and wi and wo on opposite sides have neither frame nor density.
TEST(MicrofacetReflection, SamplesCarryTheirDensityOnBothSides) {
  test::Rng rng(11);
  for (auto d : {Distribution::ggx, Distribution::beckmann}) {
    const Microfacet mf{d, 0.2};
    int drawn = 0;
    for (int i = 0; i < 500; ++i) {
      const Vec3 wo = dir_deg(i % 2 ? 160 : 35, 360 * rng.uniform());
      const auto s = bsdf::sample_reflection(mf, wo, rng.uniform2());
      if (!s) continue;
      ++drawn;
      EXPECT_GT(s->wi.z * wo.z, 0.0) << "reflection leaves wo's side";
      EXPECT_DOUBLE_EQ(s->pdf, bsdf::reflection_pdf(mf, wo, s->wi));
      // Mirroring both directions through the surface changes nothing.
      EXPECT_DOUBLE_EQ(bsdf::reflection_pdf(mf, bsdf::flip_z(wo), bsdf::flip_z(s->wi)), s->pdf);
      const auto fr = bsdf::reflection_frame(s->wi, wo);
      ASSERT_TRUE(fr);
      EXPECT_GT(fr->wo.z, 0.0);
      EXPECT_GT(fr->wi.z, 0.0);
      EXPECT_NEAR(length(fr->h), 1.0, 1e-12);
    }
    EXPECT_GT(drawn, 450);
    const Vec3 wo = dir_deg(30, 0);
    const Vec3 through = dir_deg(150, 180);
    EXPECT_FALSE(bsdf::reflection_frame(through, wo));
    EXPECT_EQ(bsdf::reflection_pdf(mf, wo, through), 0.0);
    EXPECT_FALSE(bsdf::sample_reflection(mf, Vec3{1, 0, 0}, {0.5, 0.5}));  // grazing wo
    // At the mirror direction the density is G1(wo) D(n) / (4 cos θo).
    EXPECT_NEAR(bsdf::reflection_pdf(mf, wo, reflect(wo, {0, 0, 1})),
                mf.G1(wo) * mf.D({0, 0, 1}) / (4 * wo.z), 1e-9);
  }
}

TEST(Fresnel, KnownValues) {
  // Normal incidence: ((n − 1)² + k²) / ((n + 1)² + k²).
  EXPECT_NEAR(bsdf::fresnel_conductor(1.0, 0.2, 3.9), (0.64 + 15.21) / (1.44 + 15.21), 1e-12);
  EXPECT_NEAR(bsdf::fresnel_dielectric(1.0, 1.5), 0.04, 1e-12);
  EXPECT_NEAR(bsdf::fresnel_dielectric(1.0, 1 / 1.5), 0.04, 1e-12);
  // Brewster's angle: r_p = 0, so F = r_s²/2.
  const double tb = std::atan(1.5);
  const double ci = std::cos(tb), ct = std::cos(kPi / 2 - tb);
  const double rs = (ci - 1.5 * ct) / (ci + 1.5 * ct);
  EXPECT_NEAR(bsdf::fresnel_dielectric(ci, 1.5), 0.5 * rs * rs, 1e-12);
  // Total internal reflection beyond the critical angle from inside.
  EXPECT_EQ(bsdf::fresnel_dielectric(std::cos(45 * kDegToRad), 1 / 1.5), 1.0);
  // A conductor with k = 0 is a dielectric.
  EXPECT_NEAR(bsdf::fresnel_conductor(0.6, 1.7, 0), bsdf::fresnel_dielectric(0.6, 1.7), 1e-12);
  // Grazing incidence reflects everything.
  EXPECT_NEAR(bsdf::fresnel_conductor(0.0, 0.2, 3.9), 1.0, 1e-12);
  EXPECT_NEAR(bsdf::fresnel_dielectric(0.0, 1.5), 1.0, 1e-12);
}

// The real-arithmetic conductor formula against the Fresnel equations in complex numbers.
TEST(Fresnel, ConductorMatchesComplexFresnelEquations) {
  using C = std::complex<double>;
  test::Rng rng(77);
  for (int i = 0; i < 2000; ++i) {
    const double c = rng.uniform(), eta = 1e-3 + 10 * rng.uniform(), k = 20 * rng.uniform();
    const C n(eta, k);
    const C ct = std::sqrt(C(1.0) - C(1.0 - c * c) / (n * n));
    const C rs = (C(c) - n * ct) / (C(c) + n * ct);
    const C rp = (n * c - ct) / (n * c + ct);
    const double expected = 0.5 * (std::norm(rs) + std::norm(rp));
    EXPECT_NEAR(bsdf::fresnel_conductor(c, eta, k), expected, 1e-12) << c << " " << eta << " " << k;
  }
}

TEST(Sampling, ErfInvInvertsErf) {
  for (double y : {-0.999999, -0.9, -0.3, 0.0, 1e-8, 0.5, 0.99, 0.9999999})
    EXPECT_NEAR(std::erf(bsdf::erf_inv(y)), y, 1e-14) << y;
}

}  // namespace
}  // namespace gonio::twin
