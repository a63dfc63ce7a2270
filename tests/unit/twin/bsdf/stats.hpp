// Statistical helpers for the BSDF tests: a deterministic RNG, direction helpers, the
// chi-square tail and Pearson's test (shared test support) and a chi-square
// goodness-of-fit test of a sampler against its density on a 2-D parametrisation of the
// sphere (bins with small expected counts are pooled, as in pbrt's and Mitsuba's tests).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "gonio/test/chi_square.hpp"
#include "gonio/twin/bsdf.hpp"

namespace gonio::twin::test {

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : g_(seed) {}
  double uniform() { return static_cast<double>(g_() >> 11) * 0x1.0p-53; }
  Vec2 uniform2() {
    const double a = uniform();
    return {a, uniform()};
  }
  Vec3 sphere() {  // uniform direction
    const double z = 1 - 2 * uniform();
    const double r = std::sqrt(std::max(0.0, 1 - z * z));
    const double phi = 2 * kPi * uniform();
    return {r * std::cos(phi), r * std::sin(phi), z};
  }

 private:
  std::mt19937_64 g_;
};

// Direction at polar angle theta_deg from +z (> 90: below the surface), azimuth phi_deg.
inline Vec3 dir_deg(double theta_deg, double phi_deg = 0) {
  return spherical(theta_deg * kDegToRad, phi_deg * kDegToRad);
}

// Probability that a chi-square variable with `dof` degrees of freedom exceeds `x`.
using ::gonio::test::chi2_sf;

struct Estimate {
  std::vector<double> mean, se;
  double max_weight = 0;
};

// ∫ f |cos θi| dωi per channel by importance sampling with the model's own sampler.
inline Estimate albedo_is(const Bsdf& b, const Vec3& wo, int n, std::uint64_t seed) {
  const std::size_t nc = b.channels();
  std::vector<double> s1(nc, 0), s2(nc, 0), f(nc);
  Estimate e;
  Rng rng(seed);
  for (int i = 0; i < n; ++i) {
    const double ul = rng.uniform();
    const auto s = b.sample_wi(wo, ul, rng.uniform2());
    if (!s) continue;
    b.eval(s->wi, wo, f);
    for (std::size_t c = 0; c < nc; ++c) {
      const double w = f[c] * std::abs(s->wi.z) / s->pdf;
      e.max_weight = std::max(e.max_weight, w);
      s1[c] += w;
      s2[c] += w * w;
    }
  }
  for (std::size_t c = 0; c < nc; ++c) {
    const double m = s1[c] / n;
    e.mean.push_back(m);
    e.se.push_back(std::sqrt(std::max(0.0, s2[c] / n - m * m) / (n - 1)));
  }
  return e;
}

// The same with directions drawn uniformly on the sphere: independent of sample_wi/pdf.
inline Estimate albedo_uniform(const Bsdf& b, const Vec3& wo, int n, std::uint64_t seed) {
  const std::size_t nc = b.channels();
  std::vector<double> s1(nc, 0), s2(nc, 0), f(nc);
  Rng rng(seed);
  for (int i = 0; i < n; ++i) {
    const Vec3 wi = rng.sphere();
    b.eval(wi, wo, f);
    for (std::size_t c = 0; c < nc; ++c) {
      const double w = f[c] * std::abs(wi.z) * 4 * kPi;
      s1[c] += w;
      s2[c] += w * w;
    }
  }
  Estimate e;
  for (std::size_t c = 0; c < nc; ++c) {
    const double m = s1[c] / n;
    e.mean.push_back(m);
    e.se.push_back(std::sqrt(std::max(0.0, s2[c] / n - m * m) / (n - 1)));
  }
  return e;
}

// A map of the unit square onto the sphere with its Jacobian dω/(da db), optionally
// restricted to a domain (e.g. one hemisphere): draws outside it and the density outside
// it are compared as one lump.
struct SphereMap {
  std::function<std::optional<Vec2>(const Vec3&)> to_unit;
  std::function<Vec3(Vec2, double& jacobian)> from_unit;
  std::function<bool(const Vec3&)> inside = [](const Vec3&) { return true; };
};

inline SphereMap restricted(SphereMap m, std::function<bool(const Vec3&)> inside) {
  m.inside = std::move(inside);
  return m;
}

// (cos θ, φ) over the whole sphere: a = (cos θ + 1)/2, b = φ/2π.
inline SphereMap cos_phi_map() {
  return {[](const Vec3& w) -> std::optional<Vec2> {
            double phi = std::atan2(w.y, w.x);
            if (phi < 0) phi += 2 * kPi;
            return Vec2{std::clamp((w.z + 1) / 2, 0.0, 1.0), phi / (2 * kPi)};
          },
          [](Vec2 u, double& jac) {
            jac = 4 * kPi;
            const double z = 2 * u.x - 1;
            const double r = std::sqrt(std::max(0.0, 1 - z * z));
            return Vec3{r * std::cos(2 * kPi * u.y), r * std::sin(2 * kPi * u.y), z};
          }};
}

// Polar coordinates around `axis`, the angle ψ from it stretched by `scale` (radians):
// t = ψ/(ψ + scale), a = t / t(π), so narrow lobes of width ~scale fill many bins.
inline SphereMap axis_map(const Vec3& axis, double scale) {
  const Frame f = Frame::from_normal(normalize(axis));
  const double t_max = kPi / (kPi + scale);
  return {[f, scale, t_max](const Vec3& w) -> std::optional<Vec2> {
            const Vec3 l = f.to_local(w);
            const double psi = std::acos(std::clamp(l.z, -1.0, 1.0));
            double phi = std::atan2(l.y, l.x);
            if (phi < 0) phi += 2 * kPi;
            return Vec2{std::clamp(psi / (psi + scale) / t_max, 0.0, 1.0), phi / (2 * kPi)};
          },
          [f, scale, t_max](Vec2 u, double& jac) {
            const double t = u.x * t_max;
            const double psi = scale * t / (1 - t);
            jac = t_max * scale / ((1 - t) * (1 - t)) * std::sin(psi) * 2 * kPi;
            return f.to_world(spherical(psi, 2 * kPi * u.y));
          }};
}

struct Chi2Result {
  double statistic = 0;
  double dof = 0;
  double p_value = 1;
  double pdf_integral = 0;     // ∫ pdf dω over the map's domain, by quadrature
  double success_fraction = 0; // share of draws that returned a sample
  double domain_fraction = 0;  // share of draws that landed in the map's domain
  double max_pdf_mismatch = 0; // max |sample.pdf − pdf()| / pdf()
  std::string worst;           // the bin that contributed most
};

// Draws n samples of b.sample_wi(wo, ...) and compares the histogram over `bins`² cells
// of `map` with the expected counts n ∫ pdf over each cell (midpoint rule on sub×sub
// points). Failed draws and draws outside the map's domain are compared with
// n (1 − ∫_domain pdf) as one more cell.
inline Chi2Result chi2_test(const Bsdf& b, const Vec3& wo, const SphereMap& map, int n,
                            std::uint64_t seed, int bins = 24, int sub = 8) {
  Chi2Result r;
  std::vector<double> observed(static_cast<std::size_t>(bins * bins), 0.0);
  Rng rng(seed);
  int ok = 0;
  for (int i = 0; i < n; ++i) {
    const double ul = rng.uniform();
    const auto s = b.sample_wi(wo, ul, rng.uniform2());
    if (!s) continue;
    ++ok;
    const double p = b.pdf(wo, s->wi);
    r.max_pdf_mismatch = std::max(r.max_pdf_mismatch, std::abs(s->pdf - p) / std::max(p, 1e-300));
    if (!map.inside(s->wi)) continue;
    const auto uv = map.to_unit(s->wi);
    if (!uv) continue;
    r.domain_fraction += 1.0 / n;
    const int ia = std::min(bins - 1, static_cast<int>(uv->x * bins));
    const int ib = std::min(bins - 1, static_cast<int>(uv->y * bins));
    observed[static_cast<std::size_t>(ia * bins + ib)] += 1;
  }
  r.success_fraction = static_cast<double>(ok) / n;

  std::vector<double> expected(observed.size(), 0.0);
  const double h = 1.0 / (bins * sub);
  for (int ia = 0; ia < bins; ++ia)
    for (int ib = 0; ib < bins; ++ib) {
      double s = 0;
      for (int ja = 0; ja < sub; ++ja)
        for (int jb = 0; jb < sub; ++jb) {
          double jac = 0;
          const Vec2 u{(ia * sub + ja + 0.5) * h, (ib * sub + jb + 0.5) * h};
          const Vec3 w = map.from_unit(u, jac);
          if (map.inside(w)) s += b.pdf(wo, w) * jac;
        }
      expected[static_cast<std::size_t>(ia * bins + ib)] = s * h * h;
    }
  for (const double e : expected) r.pdf_integral += e;
  for (auto& e : expected) e *= n;
  double in_domain = 0;
  for (const double o : observed) in_domain += o;
  observed.push_back(n - in_domain);  // failed draws and draws outside the domain
  expected.push_back(std::max(0.0, n * (1 - r.pdf_integral)));

  const auto test = ::gonio::test::pearson(observed, expected);
  r.statistic = test.statistic;
  r.dof = test.dof;
  r.p_value = test.p_value;
  r.worst = test.worst;
  return r;
}

}  // namespace gonio::twin::test
