// Test support for the tabulated-BSDF tests: direction builders for every parametrization,
// tables of the shared test BSDFs (gonio/test/test_bsdfs.hpp), a chi-square goodness of fit
// test, and a scratch directory.
#pragma once

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <span>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gonio/proto/error.hpp"
#include "gonio/test/chi_square.hpp"
#include "gonio/test/error_of.hpp"
#include "gonio/test/temp_dir.hpp"
#include "gonio/test/test_bsdfs.hpp"
#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/tabulated.hpp"

namespace gonio::twin::tabtest {

inline Vec3 mirror(const Vec3& w) { return {-w.x, -w.y, w.z}; }
inline Vec3 flip(const Vec3& w) { return {w.x, w.y, -w.z}; }
inline Vec3 in_plane_wi(double theta_i_deg) {
  const double t = theta_i_deg * kDegToRad;
  return {-std::sin(t), 0, std::cos(t)};
}
inline Vec3 in_plane_wr(double theta_r_deg) {
  const double t = theta_r_deg * kDegToRad;
  return {std::sin(t), 0, std::cos(t)};
}
inline Vec3 sph(double theta_deg, double phi_deg) {
  return spherical(theta_deg * kDegToRad, phi_deg * kDegToRad);
}

// Directions whose half-difference angles are (θh, φh, θd, φd), degrees (Rusinkiewicz 1998):
// wi is d rotated by θh about y then by φh about z; wo its mirror image about h.
inline void from_half_difference(double th, double ph, double td, double pd, Vec3& wi, Vec3& wo) {
  const Vec3 d = sph(td, pd);
  const double ct = std::cos(th * kDegToRad), st = std::sin(th * kDegToRad);
  const Vec3 t{ct * d.x + st * d.z, d.y, -st * d.x + ct * d.z};
  const double cp = std::cos(ph * kDegToRad), sp = std::sin(ph * kDegToRad);
  wi = {cp * t.x - sp * t.y, sp * t.x + cp * t.y, t.z};
  const Vec3 h = sph(th, ph);
  wo = h * (2 * dot(wi, h)) - wi;
}

// Direction at angle r from the mirror image of wi and azimuth a about it (degrees), in the
// documented frame: azimuth 0 toward the normal, e2 = s × e1.
inline Vec3 about_mirror(const Vec3& wi, double r_deg, double a_deg) {
  const Vec3 m = mirror(wi);
  const double st = std::sqrt(m.x * m.x + m.y * m.y);
  const Vec3 e1 = st < 1e-12 ? Vec3{-1, 0, 0} : normalize(Vec3{0, 0, 1} - m * m.z);
  const Vec3 e2 = cross(m, e1);
  const double r = r_deg * kDegToRad, a = a_deg * kDegToRad;
  return m * std::cos(r) + (e1 * std::cos(a) + e2 * std::sin(a)) * std::sin(r);
}

// A grey specular-parametrization table of `model` (channel 0), zero beyond the horizon.
inline BsdfTable specular_table(const Bsdf& model, const std::vector<double>& ti,
                                const std::vector<double>& r, const std::vector<double>& a,
                                bool bilateral, bool transmission = false) {
  std::vector<double> v;
  std::vector<double> f(model.channels());
  for (const double az : a)
    for (const double rr : r)
      for (const double t : ti) {
        const Vec3 wi{-std::sin(t * kDegToRad), 0, std::cos(t * kDegToRad)};
        Vec3 wo = about_mirror(wi, rr, az);
        double x = 0;
        if (wo.z > 0) {
          if (transmission) wo = flip(wo);
          model.eval(wi, wo, f);
          x = f[0];
        }
        v.push_back(x);
      }
  return BsdfTable(TableParam::specular, {ti, {}, r, a}, {}, v, {bilateral, false});
}

// A grey half-difference table of `model` (channel 0) with the reciprocity reduction.
inline BsdfTable half_difference_table(const Bsdf& model, const std::vector<double>& th,
                                       const std::vector<double>& td,
                                       const std::vector<double>& pd) {
  std::vector<double> v;
  std::vector<double> f(model.channels());
  for (const double p : pd)
    for (const double d : td)
      for (const double h : th) {
        Vec3 wi, wo;
        from_half_difference(h, 0, d, p, wi, wo);
        double x = 0;
        if (wi.z > 0 && wo.z > 0) {
          model.eval(wi, wo, f);
          x = f[0];
        }
        v.push_back(x);
      }
  return BsdfTable(TableParam::half_difference, {th, {}, td, pd}, {}, v, {false, true});
}

inline std::vector<double> steps(double a, double b, double s) {
  std::vector<double> v;
  for (double x = a; x <= b + 1e-9; x += s) v.push_back(x);
  return v;
}

// The test BSDFs and Pearson's test come from the shared test support library.
using ::gonio::test::tint;
using Lambert = ::gonio::test::LambertBsdf;
using Lobes = ::gonio::test::LobesBsdf;
using Specular = ::gonio::test::SpecularBsdf;

// Chi-square test of `bsdf.sample_wi(wo, …)` against `bsdf.pdf(wo, ·)` over (cos θ, φ) bins
// of the whole sphere; expected counts by midpoint integration of the pdf on a sub-grid.
// The bins' pole is perpendicular to the plane of wo and the normal, so that the mirror
// and straight-through peaks lie on the equator where the sub-grid is fine.
// Returns the p-value; also integrates the pdf and checks each sample's pdf against pdf().
struct ChiSquare {
  double p_value = 0;
  double pdf_integral = 0;
  std::size_t failed_draws = 0;
};

inline ChiSquare chi_square(const Bsdf& bsdf, const Vec3& wo, std::size_t samples,
                            std::uint64_t seed, int n_cos = 20, int n_phi = 24, int sub = 12) {
  ChiSquare res;
  Vec3 pole = cross(Vec3{0, 0, 1}, wo);
  pole = length(pole) < 1e-9 ? Vec3{0, 1, 0} : normalize(pole);
  const Vec3 ax = cross(pole, Vec3{0, 0, 1});
  const Vec3 ay = cross(pole, ax);
  const auto bin_of = [&](const Vec3& w) {
    const double cz = std::clamp(dot(w, pole), -1.0, 1.0);
    double phi = std::atan2(dot(w, ay), dot(w, ax));
    if (phi < 0) phi += 2 * kPi;
    const int i = std::min(n_cos - 1, static_cast<int>((cz + 1) / 2 * n_cos));
    const int j = std::min(n_phi - 1, static_cast<int>(phi / (2 * kPi) * n_phi));
    return static_cast<std::size_t>(i * n_phi + j);
  };
  std::vector<double> observed(static_cast<std::size_t>(n_cos * n_phi), 0.0);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  for (std::size_t k = 0; k < samples; ++k) {
    const auto s = bsdf.sample_wi(wo, uni(rng), {uni(rng), uni(rng)});
    if (!s) {
      ++res.failed_draws;
      continue;
    }
    const double p = bsdf.pdf(wo, s->wi);
    EXPECT_NEAR(s->pdf, p, 1e-9 * std::max(1.0, p)) << "sample pdf differs from pdf()";
    EXPECT_NEAR(length(s->wi), 1.0, 1e-9);
    observed[bin_of(s->wi)] += 1;
  }
  std::vector<double> expected(observed.size(), 0.0);
  const double dz = 2.0 / (n_cos * sub), dp = 2 * kPi / (n_phi * sub);
  for (int i = 0; i < n_cos * sub; ++i) {
    const double z = -1 + (i + 0.5) * dz, r = std::sqrt(std::max(0.0, 1 - z * z));
    for (int j = 0; j < n_phi * sub; ++j) {
      const double phi = (j + 0.5) * dp;
      const Vec3 w = pole * z + (ax * std::cos(phi) + ay * std::sin(phi)) * r;
      const double p = bsdf.pdf(wo, w);
      res.pdf_integral += p * dz * dp;
      expected[static_cast<std::size_t>((i / sub) * n_phi + j / sub)] += p * dz * dp;
    }
  }
  const double drawn = static_cast<double>(samples - res.failed_draws);
  for (auto& e : expected) e *= drawn / res.pdf_integral;
  res.p_value = ::gonio::test::pearson(observed, expected).p_value;
  return res;
}

// A fresh directory under the system temporary directory, removed at destruction.
using ScratchDir = ::gonio::test::TempDir;

using ::gonio::test::error_of;

}  // namespace gonio::twin::tabtest
