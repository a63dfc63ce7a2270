// Chi-square goodness of fit of sums' sample_wi against their own pdf (each model on its
// own: models_test.cpp), that the test rejects a wrong pdf, and the samplers' special cases:
// exact Lambert weights, delta lobes of the mirror, of sums and of the index-matched
// dielectric.
#include <gtest/gtest.h>

#include "chi2_cases.hpp"
#include "stats.hpp"

namespace gonio::twin {
namespace {

using test::dir_deg;

using test::Binning;
using test::Chi2Case;
using test::Side;

// Sums of lobes; each registered model on its own is tested in models_test.cpp.
class SumSamplingChi2 : public ::testing::TestWithParam<Chi2Case> {};

TEST_P(SumSamplingChi2, MatchesPdf) { test::expect_sampling_matches_pdf(GetParam()); }

std::vector<Chi2Case> sum_cases() {
  std::vector<Chi2Case> v;
  v.push_back({"lambert:albedo=0.5+coat:alpha=0.05,ior=1.5", 30.0});
  v.push_back({"lambert:albedo=0.5+coat:alpha=0.05,ior=1.5", 30.0, Binning::specular, 0.15});
  v.push_back({"oren-nayar:albedo=0.3+conductor:alpha=0.2+mirror:reflectance=0.1", 60.0});
  v.push_back({"lambert:albedo=0.2+dielectric:alpha=0.2,ior=1.5", 130.0, Binning::specular, 0.5,
               false, Side::reflection});
  v.push_back({"lambert:albedo=0.2+dielectric:alpha=0.2,ior=1.5", 130.0, Binning::refracted, 0.3,
               false, Side::transmission});
  return v;
}

INSTANTIATE_TEST_SUITE_P(Sums, SumSamplingChi2, ::testing::ValuesIn(sum_cases()));

// The test above can fail: a sampler whose reported density is off by ±5 % on either
// side of the x–z plane (still integrating to 1) is rejected.
class SkewedPdf final : public Bsdf {
 public:
  SkewedPdf() : Bsdf(WavelengthGrid::parse("550")), lambert_(make_bsdf("lambert", wavelengths())) {}
  void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const override {
    lambert_->eval(wi, wo, out);
  }
  std::optional<BsdfSample> sample_wi(const Vec3& wo, double ul, Vec2 u) const override {
    auto s = lambert_->sample_wi(wo, ul, u);
    if (s) s->pdf = pdf(wo, s->wi);
    return s;
  }
  double pdf(const Vec3& wo, const Vec3& wi) const override {
    return lambert_->pdf(wo, wi) * (wi.y > 0 ? 1.05 : 0.95);
  }
  std::string spec() const override { return "skewed"; }

 private:
  BsdfPtr lambert_;
};

TEST(Sampling, Chi2RejectsAWrongPdf) {
  const SkewedPdf b;
  const auto r = test::chi2_test(b, dir_deg(30), test::cos_phi_map(), 100000, 99);
  EXPECT_LT(r.p_value, 1e-6);
  EXPECT_NEAR(r.pdf_integral, 1.0, 2e-3);
}

// The weights f |cos θi| / pdf of Lambert are exactly the albedo: the density is
// proportional to the integrand.
TEST(Sampling, LambertWeightIsAlbedo) {
  const auto b = make_bsdf("lambert:albedo=400:0.2,700:0.8", WavelengthGrid::parse("400:700:100"));
  test::Rng rng(7);
  std::vector<double> f(b->channels());
  for (int i = 0; i < 1000; ++i) {
    const Vec3 wo = dir_deg(80 * rng.uniform(), 360 * rng.uniform());
    const auto s = b->sample_wi(wo, rng.uniform(), rng.uniform2());
    ASSERT_TRUE(s);
    b->eval(s->wi, wo, f);
    EXPECT_NEAR(f[0] * std::abs(s->wi.z) / s->pdf, 0.2, 1e-12);
    EXPECT_NEAR(f[3] * std::abs(s->wi.z) / s->pdf, 0.8, 1e-12);
  }
}

TEST(Sampling, MirrorHasOnlyADeltaLobe) {
  const auto b = make_bsdf("mirror:reflectance=400:0.5,700:0.9", WavelengthGrid::parse("400,700"));
  EXPECT_TRUE(b->has_delta());
  const Vec3 wo = dir_deg(30, 40);
  EXPECT_FALSE(b->sample_wi(wo, 0.5, {0.5, 0.5}));
  EXPECT_EQ(b->pdf(wo, reflect(wo, {0, 0, 1})), 0.0);
  std::vector<DeltaLobe> lobes;
  b->delta_lobes(wo, lobes);
  ASSERT_EQ(lobes.size(), 1u);
  EXPECT_NEAR(lobes[0].wi.x, -wo.x, 1e-15);
  EXPECT_NEAR(lobes[0].wi.y, -wo.y, 1e-15);
  EXPECT_NEAR(lobes[0].wi.z, wo.z, 1e-15);
  EXPECT_DOUBLE_EQ(lobes[0].weight[0], 0.5);
  EXPECT_DOUBLE_EQ(lobes[0].weight[1], 0.9);
}

TEST(Sampling, SumListsDeltaLobesOfItsParts) {
  const auto b = make_bsdf("lambert:albedo=0.5+mirror:reflectance=0.25", WavelengthGrid::parse("550"));
  EXPECT_TRUE(b->has_delta());
  std::vector<DeltaLobe> lobes;
  b->delta_lobes(dir_deg(45), lobes);
  ASSERT_EQ(lobes.size(), 1u);
  EXPECT_DOUBLE_EQ(lobes[0].weight[0], 0.25);
  // The mirror adds nothing to the density: the sum samples the Lambertian part only.
  const Vec3 wo = dir_deg(45);
  const Vec3 wi = dir_deg(20, 180);
  EXPECT_NEAR(b->pdf(wo, wi), wi.z / kPi, 1e-15);
}

TEST(Sampling, IndexMatchedDielectricIsStraightThrough) {
  const auto b = make_bsdf("dielectric:alpha=0.3,ior=1", WavelengthGrid::parse("550"));
  EXPECT_TRUE(b->has_delta());
  const Vec3 wo = dir_deg(150, 10);
  std::vector<DeltaLobe> lobes;
  b->delta_lobes(wo, lobes);
  ASSERT_EQ(lobes.size(), 1u);
  EXPECT_NEAR(lobes[0].wi.z, -wo.z, 1e-15);
  EXPECT_DOUBLE_EQ(lobes[0].weight[0], 1.0);
  EXPECT_FALSE(b->sample_wi(wo, 0.3, {0.2, 0.7}));
}

}  // namespace
}  // namespace gonio::twin
