// The layered paint model against data it did not make: a coated diffuser written here from
// its formulas alone (Trowbridge–Reitz in its original form, Smith masking in closed form,
// Fresnel in complex arithmetic, the interface's albedo by brute-force quadrature over the
// hemisphere) sharing no code with twin/src/bsdf/plastic.cpp; the fit must recover its
// parameters, and a Lambertian base plus a coat — which cannot fall off at grazing angles
// as a layered paint does — must be reported as a misfit.
#include <cmath>
#include <complex>
#include <numbers>
#include <random>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/twin/fit.hpp"
#include "gonio/test/ideal_instrument.hpp"

namespace gonio::twin {
namespace {

constexpr double kPiD = std::numbers::pi;

// Unpolarised Fresnel reflectance of a dielectric of relative index n, from the complex
// amplitude coefficients (Born & Wolf §1.5.2), cos_i on the incident side.
double fresnel(double cos_i, double n) {
  const std::complex<double> ci(cos_i, 0);
  const std::complex<double> ct = std::sqrt(std::complex<double>(1.0 - (1.0 - cos_i * cos_i) / (n * n), 0));
  const auto rs = (ci - n * ct) / (ci + n * ct);
  const auto rp = (n * ci - ct) / (n * ci + ct);
  return 0.5 * (std::norm(rs) + std::norm(rp));
}

struct ReferencePlastic {
  double alpha, ior;
  std::vector<double> albedo;

  // Trowbridge & Reitz 1975 in Walter et al.'s form: 1 / (π α² cos⁴θm (1 + tan²θm/α²)²).
  double D(double cos_m) const {
    if (cos_m <= 0) return 0;
    const double c2 = cos_m * cos_m, t2 = (1 - c2) / c2;
    const double k = 1 + t2 / (alpha * alpha);
    return 1 / (kPiD * alpha * alpha * c2 * c2 * k * k);
  }
  // Smith Λ for GGX: (√(1 + α² tan²θ) − 1) / 2.
  double lambda(double cos_t) const {
    const double t2 = (1 - cos_t * cos_t) / (cos_t * cos_t);
    return (std::sqrt(1 + alpha * alpha * t2) - 1) / 2;
  }
  // The interface's reflection, wi and wo as (θ, φ) pairs on the upper hemisphere.
  double specular(double ti, double pi_, double to, double po) const {
    const double wi[3] = {std::sin(ti) * std::cos(pi_), std::sin(ti) * std::sin(pi_), std::cos(ti)};
    const double wo[3] = {std::sin(to) * std::cos(po), std::sin(to) * std::sin(po), std::cos(to)};
    double h[3] = {wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]};
    const double len = std::sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    for (double& v : h) v /= len;
    const double cos_d = wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2];
    const double g2 = 1 / (1 + lambda(wi[2]) + lambda(wo[2]));
    return fresnel(cos_d, ior) * D(h[2]) * g2 / (4 * wi[2] * wo[2]);
  }
  // R(θ) = ∫ f_s cos θi dωi: Gauss–Legendre in cos θi, midpoint in φi.
  double R(double theta) const {
    std::vector<double> x, w;
    test::gauss_legendre(160, x, w);
    constexpr int kPhi = 360;
    double sum = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      const double mu = 0.5 * (x[i] + 1);
      for (int j = 0; j < kPhi; ++j) {
        const double phi = 2 * kPiD * (j + 0.5) / kPhi;
        sum += 0.5 * w[i] * (2 * kPiD / kPhi) * specular(std::acos(mu), phi, theta, 0) * mu;
      }
    }
    return sum;
  }
  // R̄ = ∫ R(θ) 2 cos θ sin θ dθ.
  double R_mean() const {
    std::vector<double> x, w;
    test::gauss_legendre(24, x, w);
    double s = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      const double mu = 0.5 * (x[i] + 1);
      s += 0.5 * w[i] * R(std::acos(mu)) * 2 * mu;
    }
    return s;
  }
};

struct Synthetic {
  MeasuredData data;
  ReferencePlastic truth;
};

// In-plane β = π f at θi = 10…70°, θr = −80…80° every 5°, noise-free.
const Synthetic& clean() {
  static const Synthetic s = [] {
    Synthetic out;
    out.truth = {0.15, 1.5, {0.1, 0.3, 0.6, 0.8}};
    const auto& t = out.truth;
    out.data.wavelengths = WavelengthGrid::parse("400:700:100");
    out.data.source = "reference plastic";
    out.data.exact_directions = true;
    const double e = (1 - t.R_mean()) / (t.ior * t.ior);
    std::vector<std::pair<double, double>> r_cache;
    const auto R = [&](double deg) {
      for (const auto& [d, v] : r_cache)
        if (d == deg) return v;
      const double v = t.R(deg * kPiD / 180);
      r_cache.emplace_back(deg, v);
      return v;
    };
    for (double ti : {10.0, 30.0, 50.0, 70.0})
      for (double tr = -80; tr <= 80; tr += 5) {
        MeasuredPoint p{Geometry::in_plane(ti, tr), {}, {}};
        const double a = ti * kPiD / 180, b = std::abs(tr) * kPiD / 180;
        // Incident from −x (φ = π), received at +x (φ = 0) for θr > 0.
        const double fs = t.specular(a, kPiD, b, tr >= 0 ? 0 : kPiD);
        const double tt = (1 - R(ti)) * (1 - R(std::abs(tr)));
        for (const double rho : t.albedo) {
          const double f = fs + rho * tt / (kPiD * t.ior * t.ior * (1 - rho * (1 - e)));
          p.beta.push_back(kPiD * f);
          p.u.push_back(0.01 * kPiD * f + 0.001);
        }
        out.data.points.push_back(std::move(p));
      }
    return out;
  }();
  return s;
}

// The same with Gaussian noise of the stated u (1 % + 0.001).
Synthetic synthesise(std::uint32_t seed) {
  Synthetic s = clean();
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss;
  for (auto& p : s.data.points)
    for (std::size_t c = 0; c < p.beta.size(); ++c) p.beta[c] += p.u[c] * gauss(rng);
  return s;
}

TEST(Plastic, RecoversAnIndependentLayeredPaint) {
  const auto s = synthesise(7);
  FitOptions o;
  const auto r = fit_material(s.data, "plastic:albedo=?*,alpha=?,ior=?", InstrumentProfile::preset("gcms4"), o);
  ASSERT_EQ(r.parameters.size(), 6u);
  EXPECT_TRUE(r.nominal_directions);
  EXPECT_LT(r.chi2_per_dof, 1.5) << r.to_json().dump(1);
  for (std::size_t c = 0; c < 4; ++c) {
    const auto& p = r.parameters[c];
    EXPECT_NEAR(p.value, s.truth.albedo[c], 4 * p.u + 1e-3) << p.name;
  }
  EXPECT_NEAR(r.parameters[4].value, s.truth.alpha, 4 * r.parameters[4].u + 1e-3);
  EXPECT_NEAR(r.parameters[5].value, s.truth.ior, 4 * r.parameters[5].u + 1e-3);
  for (const auto& w : r.warnings) ADD_FAILURE() << "unexpected warning: " << w;
}

TEST(Plastic, ALambertianBaseUnderACoatIsReportedAsAMisfit) {
  const auto s = synthesise(8);
  const auto profile = InstrumentProfile::preset("gcms4");
  const auto plastic = fit_material(s.data, "plastic:albedo=?*,alpha=?,ior=?", profile);
  const auto sum = fit_material(s.data, "lambert:albedo=?*+coat:alpha=?,ior=?", profile);
  EXPECT_GT(sum.chi2_per_dof, 3 * plastic.chi2_per_dof);
  ASSERT_GT(sum.chi2_per_dof, FitOptions{}.misfit_limit);
  ASSERT_FALSE(sum.warnings.empty());
  EXPECT_NE(sum.warnings.front().find("does not describe the data"), std::string::npos)
      << sum.warnings.front();
  ASSERT_FALSE(sum.misfit.empty());
  double share = 0;
  for (std::size_t k = 0; k < sum.misfit.size(); ++k) {
    share += sum.misfit[k].chi2_share;
    if (k > 0) {
      EXPECT_LE(sum.misfit[k].chi2_share, sum.misfit[k - 1].chi2_share);
    }
  }
  EXPECT_LE(share, 1 + 1e-12);
  // The worst region is named in the warning.
  EXPECT_NE(sum.warnings.front().find(fmt::format("θi = {:g}°", sum.misfit.front().theta_i)),
            std::string::npos);
}

// Honest uncertainties: over 20 noise seeds the truth lies within 2 u of the fitted α and
// ior in at least 17 (coverage 95 %: 19 expected, 17 or more with probability 0.92 each,
// both together about 0.85 — a test that fails one run in seven would be no test, so the
// bound counts both parameters' 40 cases against 35).
TEST(Plastic, UncertaintiesCoverTheTruthOverNoiseSeeds) {
#ifndef NDEBUG
  GTEST_SKIP() << "statistical target (20 fits): run in an optimised build";
#endif
  const auto profile = InstrumentProfile::preset("gcms4");
  int within = 0, total = 0;
  double sum_z2 = 0;
  for (std::uint32_t seed = 100; seed < 120; ++seed) {
    const auto s = synthesise(seed);
    const auto r = fit_material(s.data, "plastic:albedo=?*,alpha=?,ior=?", profile);
    for (const auto& [k, truth] : {std::pair{4u, s.truth.alpha}, std::pair{5u, s.truth.ior}}) {
      const double z = (r.parameters[k].value - truth) / r.parameters[k].u;
      sum_z2 += z * z;
      within += std::abs(z) <= 2 ? 1 : 0;
      ++total;
    }
  }
  EXPECT_GE(within, 35) << "of " << total;
  // Neither overstated: an RMS z far below 1 would mean uncertainties too wide.
  EXPECT_GT(std::sqrt(sum_z2 / total), 0.6);
}

}  // namespace
}  // namespace gonio::twin
