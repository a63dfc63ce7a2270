// Energy conservation of sums and of special cases (∫ f |cos θi| dωi ≤ 1 per channel,
// = albedo for Lambert; each registered model's own furnace and reciprocity tests are in
// models_test.cpp), agreement of the importance-sampled estimate with an independent
// uniform-sphere estimate, reciprocity of sums, generalised reciprocity of the dielectric's
// transmission, and per-channel spectral evaluation.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "stats.hpp"

namespace gonio::twin {
namespace {

using test::dir_deg;

using test::albedo_is;
using test::albedo_uniform;

std::string fmt_spec(double eta, double k) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "conductor:alpha=0.1,eta=%.17g,k=%.17g", eta, k);
  return buf;
}

const WavelengthGrid& grid() {
  static const auto g = WavelengthGrid::parse("400:700:100");
  return g;
}

// Sums of lobes; each registered model on its own is tested in models_test.cpp.
const std::vector<std::string>& sums() {
  static const std::vector<std::string> specs{
      "lambert:albedo=0.4+coat:alpha=0.05,ior=1.5",
      "oren-nayar:albedo=0.4,sigma=10+conductor:alpha=0.2,eta=1,k=1",
  };
  return specs;
}

TEST(Energy, AlbedoOfSumsAtMostOneForEveryChannel) {
  for (const auto& spec : sums()) {
    const auto b = make_bsdf(spec, grid());
    const bool two_sided_medium = spec.rfind("dielectric", 0) == 0;
    for (double t : {0.0, 30.0, 60.0, 85.0, 89.5, 120.0, 175.0}) {
      if (t > 90 && !two_sided_medium && spec.find("lambert") != 0) continue;
      const Vec3 wo = dir_deg(t, 20);
      const auto e = albedo_is(*b, wo, 10000, 11);
      for (std::size_t c = 0; c < e.mean.size(); ++c)
        EXPECT_LE(e.mean[c], 1.0 + 4 * e.se[c] + 1e-3)
            << spec << " θo=" << t << " channel " << grid()[c] << " nm";
    }
  }
}

// Microfacet models (single scattering) and Lambert weigh every sample by at most 1:
// weights are F·G2/G1 or the albedo. Oren–Nayar is excluded (its B term is not bounded).
// A sum adds its parts' albedos (it does not attenuate one lobe by another), so a sum
// conserves energy only when its parts' albedos add up to at most 1: the diffuse base
// and the coat's Fresnel reflectance at grazing incidence (~0.9) do not.
TEST(Energy, SumAddsTheAlbedosOfItsParts) {
  const auto sum = make_bsdf("lambert:albedo=0.5+coat:alpha=0.05,ior=1.5", grid());
  const auto coat = make_bsdf("coat:alpha=0.05,ior=1.5", grid());
  for (double t : {30.0, 89.5}) {
    const auto e = albedo_is(*sum, dir_deg(t), 40000, 12);
    const auto ec = albedo_is(*coat, dir_deg(t), 40000, 13);
    EXPECT_NEAR(e.mean[0], 0.5 + ec.mean[0], 5 * std::hypot(e.se[0], ec.se[0]) + 1e-4) << t;
    if (t > 89) {
      EXPECT_GT(e.mean[0], 1.0);
    }
  }
}

TEST(Energy, SampleWeightsBoundedForMicrofacetModels) {
  for (const char* spec : {"conductor:alpha=0.5,eta=0.2,k=3.9", "beckmann:alpha=0.05",
                           "dielectric:alpha=0.2,ior=1.5", "coat:alpha=0.3,ior=1.5",
                           "lambert:albedo=1"})
    for (double t : {0.0, 50.0, 88.0, 130.0}) {
      const auto b = make_bsdf(spec, grid());
      EXPECT_LE(albedo_is(*b, dir_deg(t), 5000, 3).max_weight, 1.0 + 1e-9) << spec << " " << t;
    }
}

TEST(Energy, LambertAlbedoIsExact) {
  const auto b = make_bsdf("lambert:albedo=400:0.1,700:0.9", grid());
  const std::vector<double> albedo{0.1, 0.1 + 0.8 / 3, 0.1 + 1.6 / 3, 0.9};
  for (double t : {0.0, 45.0, 89.0, 160.0}) {
    const auto e = albedo_is(*b, dir_deg(t), 2000, 5);
    const auto u = albedo_uniform(*b, dir_deg(t), 200000, 6);
    for (std::size_t c = 0; c < 4; ++c) {
      EXPECT_NEAR(e.mean[c], albedo[c], 1e-12);
      EXPECT_NEAR(u.mean[c], albedo[c], 5 * u.se[c]);
    }
  }
}

// Importance sampling and uniform sampling estimate the same integral: eval, sample_wi
// and pdf agree with each other (wide lobes only, where uniform sampling converges).
TEST(Energy, ImportanceAndUniformEstimatesAgree) {
  for (const char* spec : {"oren-nayar:albedo=0.9,sigma=40", "conductor:alpha=0.6,eta=0.3,k=3",
                           "beckmann:alpha=0.4,eta=1.5,k=2", "dielectric:alpha=0.5,ior=1.5",
                           "coat:alpha=0.4,ior=1.8", "lambert:albedo=0.3+coat:alpha=0.5"})
    for (double t : {10.0, 70.0, 140.0}) {
      const auto b = make_bsdf(spec, grid());
      const auto e = albedo_is(*b, dir_deg(t, 10), 20000, 21);
      const auto u = albedo_uniform(*b, dir_deg(t, 10), 100000, 22);
      for (std::size_t c = 0; c < e.mean.size(); ++c)
        EXPECT_NEAR(e.mean[c], u.mean[c], 5 * std::hypot(e.se[c], u.se[c]) + 1e-4)
            << spec << " θo=" << t;
    }
}

// With Fresnel ≈ 1 (η → 0, large k: a perfect conductor) and a narrow lobe, nothing is
// lost: the reflected energy is 1.
TEST(Energy, PerfectConductorNarrowLobeReflectsEverything) {
  for (const char* spec : {"conductor:alpha=0.001,eta=1e-6,k=20", "beckmann:alpha=0.001,eta=1e-6,k=20"}) {
    const auto b = make_bsdf(spec, grid());
    const auto e = albedo_is(*b, dir_deg(30), 20000, 9);
    EXPECT_NEAR(e.mean[0], 1.0, 2e-3) << spec;
  }
}

// The dielectric's reflected plus transmitted energy for a narrow lobe at normal
// incidence is ~1 (single scattering loses almost nothing), split by Fresnel.
TEST(Energy, SmoothishDielectricSplitsByFresnel) {
  const auto b = make_bsdf("dielectric:alpha=0.001,ior=1.5", grid());
  const Vec3 wo = dir_deg(0);
  const int n = 20000;
  test::Rng rng(4);
  double refl = 0, trans = 0;
  std::vector<double> f(b->channels());
  for (int i = 0; i < n; ++i) {
    const double ul = rng.uniform();
    const auto s = b->sample_wi(wo, ul, rng.uniform2());
    if (!s) continue;
    b->eval(s->wi, wo, f);
    (s->wi.z > 0 ? refl : trans) += f[0] * std::abs(s->wi.z) / s->pdf / n;
  }
  const double f0 = (0.5 / 2.5) * (0.5 / 2.5);  // ((η−1)/(η+1))²
  EXPECT_NEAR(refl, f0, 0.01);
  EXPECT_NEAR(refl + trans, 1.0, 2e-3);
}

TEST(Reciprocity, SumsAreSymmetric) {
  test::Rng rng(31);
  std::vector<double> a(grid().size()), b2(grid().size());
  for (const auto& spec : sums()) {
    const auto b = make_bsdf(spec, grid());
    for (int i = 0; i < 300; ++i) {
      Vec3 wi = rng.sphere(), wo = rng.sphere();
      if (wi.z * wo.z < 0) wi = Vec3{wi.x, wi.y, -wi.z};  // same side: reflection
      b->eval(wi, wo, a);
      b->eval(wo, wi, b2);
      for (std::size_t c = 0; c < a.size(); ++c)
        EXPECT_NEAR(a[c], b2[c], 1e-10 * std::max(1.0, std::abs(a[c]))) << spec;
    }
  }
}

// f(wi, wo)/η_i² = f(wo, wi)/η_o² across the dielectric interface.
TEST(Reciprocity, DielectricTransmissionIsGeneralisedReciprocal) {
  for (double ior : {1.33, 1.5, 2.4}) {
    const auto b = make_bsdf("dielectric:alpha=0.4,ior=" + std::to_string(ior), grid());
    test::Rng rng(32);
    std::vector<double> a(grid().size()), r(grid().size());
    int nonzero = 0;
    for (int i = 0; i < 500; ++i) {
      Vec3 wi = rng.sphere(), wo = rng.sphere();
      if (wi.z * wo.z > 0) wi = Vec3{wi.x, wi.y, -wi.z};  // opposite sides: transmission
      b->eval(wi, wo, a);
      b->eval(wo, wi, r);
      const double eta_i = wi.z > 0 ? 1.0 : ior;
      const double eta_o = wo.z > 0 ? 1.0 : ior;
      EXPECT_NEAR(a[0] / (eta_i * eta_i), r[0] / (eta_o * eta_o), 1e-10 * std::max(1.0, a[0]));
      nonzero += a[0] > 0;
    }
    EXPECT_GT(nonzero, 40);  // the check above is not vacuous
  }
}

// Every channel is evaluated with its own resampled parameters.
TEST(Spectral, ChannelsMatchSingleWavelengthModels) {
  const auto b = make_bsdf("conductor:alpha=0.1,eta=400:0.2,700:1.4,k=400:3,700:6", grid());
  const Vec3 wi = dir_deg(35, 180), wo = dir_deg(30, 10);
  std::vector<double> f(grid().size());
  b->eval(wi, wo, f);
  for (std::size_t c = 0; c < grid().size(); ++c) {
    const double t = (grid()[c] - 400) / 300;
    const double eta = 0.2 + t * 1.2, k = 3 + t * 3;
    const auto one = make_bsdf(fmt_spec(eta, k), WavelengthGrid({grid()[c]}));
    std::vector<double> g(1);
    one->eval(wi, wo, g);
    EXPECT_NEAR(f[c], g[0], 1e-12 * g[0]) << grid()[c];
  }
}

}  // namespace
}  // namespace gonio::twin
