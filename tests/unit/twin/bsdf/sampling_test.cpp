// Chi-square goodness of fit of every model's sample_wi against its own pdf, for several
// receiver directions (normal, oblique, grazing, and below the surface for the
// dielectric), and the pdf's integral over the sphere. Narrow lobes are binned around
// their peak so that α = 0.001 is resolved.
#include <gtest/gtest.h>

#include <ostream>

#include "stats.hpp"

namespace gonio::twin {
namespace {

using test::dir_deg;

enum class Binning { sphere, specular, refracted };
// Where draws are binned: everywhere, or only on the receiver's side (reflection) or the
// other side (transmission), so that each binning resolves the one peak it holds.
enum class Side { all, reflection, transmission };

struct Case {
  std::string spec;
  double theta_o;  // degrees from +z; > 90 is below the surface
  Binning binning = Binning::sphere;
  double scale = 0;  // angular scale of the axis binning, radians
  bool lossless = false;  // the pdf integrates to 1
  Side side = Side::all;
};

std::ostream& operator<<(std::ostream& os, const Case& c) {
  static const char* const sides[] = {"", " (reflection side)", " (transmission side)"};
  return os << c.spec << " @ " << c.theta_o << " deg" << sides[static_cast<int>(c.side)];
}

// Refraction of the macro-surface for the axis of transmission lobes.
Vec3 refracted(const Vec3& wo, double ior) {
  const bool below = wo.z < 0;
  const double e = below ? 1 / ior : ior;
  const Vec3 n{0, 0, below ? -1.0 : 1.0};
  const double c = std::abs(wo.z);
  const double s2 = (1 - c * c) / (e * e);
  const double ct = std::sqrt(std::max(0.0, 1 - s2));
  return normalize(-wo / e + (c / e - ct) * n);
}

class SamplingChi2 : public ::testing::TestWithParam<Case> {};

TEST_P(SamplingChi2, MatchesPdf) {
  const Case& c = GetParam();
  const auto grid = WavelengthGrid::parse("450,550,650");
  const auto b = make_bsdf(c.spec, grid);
  const Vec3 wo = dir_deg(c.theta_o, 30);
  test::SphereMap map = test::cos_phi_map();
  if (c.binning == Binning::specular) map = test::axis_map(reflect(wo, {0, 0, 1}), c.scale);
  if (c.binning == Binning::refracted) {
    const auto pos = c.spec.find("ior=");
    map = test::axis_map(refracted(wo, std::stod(c.spec.substr(pos + 4))), c.scale);
  }
  if (c.side != Side::all) {
    const bool same = c.side == Side::reflection;
    map = test::restricted(map, [wo, same](const Vec3& w) { return (w.z * wo.z > 0) == same; });
  }
  const int n = 60000;
  const auto r = test::chi2_test(*b, wo, map, n, 0x5eed + static_cast<std::uint64_t>(c.theta_o));
  // About 60 cases: a 1e-4 significance level keeps the family-wise false alarm rate
  // under 1 % (Šidák), and the seeds are fixed.
  EXPECT_GT(r.p_value, 1e-4) << "chi2 = " << r.statistic << " with " << r.dof
                             << " dof; worst " << r.worst;
  EXPECT_LT(r.max_pdf_mismatch, 1e-6);
  EXPECT_LE(r.pdf_integral, 1.0 + 2e-3);
  EXPECT_GT(r.success_fraction, 0.0);
  if (c.lossless) {
    EXPECT_NEAR(r.pdf_integral, 1.0, 2e-3);
  }
}

std::vector<Case> cases() {
  std::vector<Case> v;
  for (double t : {0.0, 45.0, 89.0, 120.0}) v.push_back({"lambert:albedo=0.7", t, Binning::sphere, 0, true});
  for (double t : {30.0, 80.0, 135.0})
    v.push_back({"oren-nayar:albedo=0.6,sigma=30", t, Binning::sphere, 0, true});
  for (const char* d : {"conductor", "beckmann"}) {
    const std::string name(d);
    for (double t : {0.0, 40.0, 80.0}) v.push_back({name + ":alpha=0.5", t});
    for (double t : {0.0, 40.0, 80.0})
      v.push_back({name + ":alpha=0.05", t, Binning::specular, 0.15});
    for (double t : {10.0, 60.0, 87.0})
      v.push_back({name + ":alpha=0.001", t, Binning::specular, 0.003});
    v.push_back({name + ":alpha=1", 70.0});
    v.push_back({name + ":alpha=0.2", 150.0});  // receiver below: two-sided
  }
  // The dielectric: each receiver direction twice, binned around the reflected peak on
  // wo's side and around the refracted peak on the other side.
  const auto dielectric = [&v](const std::string& spec, double t, double scale) {
    v.push_back({spec, t, Binning::specular, scale, false, Side::reflection});
    v.push_back({spec, t, Binning::refracted, scale, false, Side::transmission});
  };
  for (double t : {0.0, 45.0, 80.0, 120.0, 170.0}) dielectric("dielectric:alpha=0.3,ior=1.5", t, 0.5);
  for (double t : {30.0, 140.0}) dielectric("dielectric:alpha=0.02,ior=1.5", t, 0.04);
  for (double t : {45.0, 160.0}) dielectric("dielectric:alpha=0.001,ior=1.5", t, 0.002);
  dielectric("dielectric:alpha=0.1,ior=2.4", 60.0, 0.2);
  dielectric("dielectric:alpha=0.1,ior=1.33", 100.0, 0.2);  // from inside, near grazing: TIR
  for (double t : {20.0, 75.0}) v.push_back({"coat:alpha=0.05,ior=1.5", t, Binning::specular, 0.15});
  v.push_back({"lambert:albedo=0.5+coat:alpha=0.05,ior=1.5", 30.0});
  v.push_back({"lambert:albedo=0.5+coat:alpha=0.05,ior=1.5", 30.0, Binning::specular, 0.15});
  v.push_back({"oren-nayar:albedo=0.3+conductor:alpha=0.2+mirror:reflectance=0.1", 60.0});
  v.push_back({"lambert:albedo=0.2+dielectric:alpha=0.2,ior=1.5", 130.0, Binning::specular, 0.5,
               false, Side::reflection});
  v.push_back({"lambert:albedo=0.2+dielectric:alpha=0.2,ior=1.5", 130.0, Binning::refracted, 0.3,
               false, Side::transmission});
  return v;
}

INSTANTIATE_TEST_SUITE_P(Models, SamplingChi2, ::testing::ValuesIn(cases()));

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
