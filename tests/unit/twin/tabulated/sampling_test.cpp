// Sampling of tabulated BSDFs: chi-square of the drawn directions against pdf() for every
// parametrization, reflection and transmission, isotropic and anisotropic tables and
// receivers above and below the sample; the pdf integrates to one; importance sampling
// beats cosine sampling on a narrow lobe.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "gonio/twin/tabulated.hpp"
#include "tab_testing.hpp"

namespace gonio::twin {
namespace {

using tabtest::sph;
using tabtest::steps;

const WavelengthGrid& grid() {
  static const WavelengthGrid g = WavelengthGrid::parse("450,550,650");
  return g;
}

AngularGrid iso_grid(double dti, double dto, double dphi) {
  AngularGrid ag;
  ag.theta_i = steps(0, 85, dti);
  ag.theta_o = steps(0, 90, dto);
  ag.phi_o = steps(0, 180, dphi);
  ag.bilateral = true;
  return ag;
}

void check_sampling(const Bsdf& b, const Vec3& wo, std::uint64_t seed, const char* what) {
  const auto res = tabtest::chi_square(b, wo, 30000, seed);
  EXPECT_GT(res.p_value, 1e-3) << what << ": chi-square rejects the sampler, wo = (" << wo.x
                               << ", " << wo.y << ", " << wo.z << ")";
  EXPECT_NEAR(res.pdf_integral, 1.0, 5e-3) << what;
  EXPECT_LT(res.failed_draws, 300u) << what;
}

const std::vector<Vec3>& receivers() {
  static const std::vector<Vec3> w{sph(0, 0), sph(33, 20), sph(78, 250),
                                   tabtest::flip(sph(47, 130))};
  return w;
}

TEST(TableSampling, LambertReflection) {
  const tabtest::Lambert model(grid(), 0.7);
  const TabulatedBsdf t(grid(), tabulate_parts(model, iso_grid(15, 10, 30)));
  std::uint64_t seed = 100;
  for (const auto& wo : receivers()) check_sampling(t, wo, seed++, "lambert");
}

TEST(TableSampling, GlossyLobeSpherical) {
  const tabtest::Lobes model(grid(), 0.1, 0.8, 60);
  const TabulatedBsdf t(grid(), tabulate_parts(model, iso_grid(5, 2, 5)));
  std::uint64_t seed = 200;
  for (const auto& wo : receivers()) check_sampling(t, wo, seed++, "glossy spherical");
}

TEST(TableSampling, ReflectionAndTransmission) {
  const tabtest::Lobes model(grid(), 0.1, 0.5, 30, 0.4, 40);
  const TabulatedBsdf t(grid(), tabulate_parts(model, iso_grid(5, 3, 10), true, true));
  std::uint64_t seed = 300;
  for (const auto& wo : receivers()) check_sampling(t, wo, seed++, "reflection + transmission");
}

TEST(TableSampling, Anisotropic) {
  const tabtest::Lobes model(grid(), 0.15, 0.6, 25, 0, 1, 2.0);
  AngularGrid ag;
  ag.theta_i = steps(0, 80, 10);
  ag.phi_i = steps(0, 330, 30);
  ag.theta_o = steps(0, 90, 6);
  ag.phi_o = steps(0, 345, 15);
  const TabulatedBsdf t(grid(), tabulate_parts(model, ag));
  std::uint64_t seed = 400;
  for (const auto& wo : {sph(25, 40), sph(60, 200)}) check_sampling(t, wo, seed++, "anisotropic");
}

TEST(TableSampling, SpecularAndHalfDifferenceParametrizations) {
  const tabtest::Lobes model(grid(), 0.1, 0.8, 80);
  TabulatedParts sp;
  sp.brdf = tabtest::specular_table(model, steps(0, 80, 10),
                                    {0, 1, 2, 3, 5, 7, 10, 15, 20, 30, 45, 60, 90, 120, 180},
                                    steps(0, 180, 15), true);
  const TabulatedBsdf ts(grid(), sp);
  std::uint64_t seed = 500;
  for (const auto& wo : receivers()) check_sampling(ts, wo, seed++, "specular table");

  TabulatedParts hd;
  std::vector<double> th;
  for (int k = 0; k < 30; ++k) th.push_back(90.0 * (k / 30.0) * (k / 30.0));
  hd.brdf = tabtest::half_difference_table(model, th, steps(0, 87, 3), steps(0, 170, 10));
  const TabulatedBsdf th_b(grid(), hd);
  for (const auto& wo : receivers()) check_sampling(th_b, wo, seed++, "half-difference table");
}

// For a narrow lobe the sampler must concentrate where f·cos is: the variance of
// f̄·cos/pdf is far below that of cosine-weighted sampling, and both estimate the same
// directional albedo.
TEST(TableSampling, ImportanceSamplingReducesVariance) {
  const tabtest::Lobes model(grid(), 0.02, 0.9, 400);
  const TabulatedBsdf t(grid(), tabulate_parts(model, iso_grid(5, 1, 2)));
  const Vec3 wo = sph(40, 0);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int n = 20000;
  double s1 = 0, s2 = 0, c1 = 0, c2 = 0;
  for (int k = 0; k < n; ++k) {
    const auto s = t.sample_wi(wo, u(rng), {u(rng), u(rng)});
    const double x = s ? t.eval_mean(s->wi, wo) * std::abs(s->wi.z) / s->pdf : 0.0;
    s1 += x;
    s2 += x * x;
    // Cosine-weighted hemisphere: estimator f·cos/(cos/π) = π f.
    const double r = std::sqrt(u(rng)), phi = 2 * kPi * u(rng);
    const Vec3 w{r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0, 1 - r * r))};
    const double y = kPi * t.eval_mean(w, wo);
    c1 += y;
    c2 += y * y;
  }
  const double mi = s1 / n, vi = s2 / n - mi * mi, mc = c1 / n, vc = c2 / n - mc * mc;
  EXPECT_LT(vi, 0.05 * vc) << "importance variance " << vi << " vs cosine " << vc;
  EXPECT_NEAR(mi, mc, 4 * std::sqrt(vc / n + vi / n));
  EXPECT_GT(mi, 0.5);
}

TEST(TableSampling, ZeroTableStillDrawsValidDirections) {
  TabulatedParts p;
  p.brdf = BsdfTable(TableParam::spherical, {{0, 45}, {}, {0, 90}, {0}}, {}, {0, 0, 0, 0});
  const TabulatedBsdf t(grid(), p);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int k = 0; k < 200; ++k) {
    const auto s = t.sample_wi(sph(30, 0), u(rng), {u(rng), u(rng)});
    ASSERT_TRUE(s);
    EXPECT_GT(s->wi.z, 0);
    EXPECT_NEAR(s->pdf, s->wi.z * kInvPi, 1e-12);
  }
}

}  // namespace
}  // namespace gonio::twin
