// An independent model of the ideal instrument, for tests and benchmarks of the inverse
// twin: the radiance factor as a deterministic tensor-product Gauss–Legendre quadrature of
// f |cos θo| over the source and receiver apertures, divided by the same quadrature of a
// perfect white diffuser. It shares no code with the twin's estimator: directions come from
// tangent-plane coordinates (ω = normalize(a + x t + y p), dω = cos³γ dx dy) and the lit
// area is not clipped — for a beam whose footprint lies inside the viewed area and on the
// sample, A |cos θi| is the beam's cross-section (perpendicular to the source's axis) seen
// along ωi, S cos γi, so only f |cos θo| cos γi remains.
#pragma once

#include <array>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/fit.hpp"
#include "gonio/twin/instrument.hpp"

namespace gonio::twin::test {

// Gauss–Legendre nodes and weights on [−1, 1] by Newton iteration on P_n (Golub–Welsch
// would do as well; n is small).
inline void gauss_legendre(int n, std::vector<double>& x, std::vector<double>& w) {
  x.assign(static_cast<std::size_t>(n), 0.0);
  w.assign(static_cast<std::size_t>(n), 0.0);
  for (int i = 0; i < n; ++i) {
    double z = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5));
    double dp = 1;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1, p1 = z;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (z * p1 - p0) / (z * z - 1);
      const double dz = p1 / dp;
      z -= dz;
      if (std::abs(dz) < 1e-15) break;
    }
    x[static_cast<std::size_t>(i)] = z;
    w[static_cast<std::size_t>(i)] = 2 / ((1 - z * z) * dp * dp);
  }
}

struct IdealInstrument {
  InstrumentProfile profile = InstrumentProfile::preset("gcms4");
  double gain = 1;
  int nodes = 10;  // per dimension of each aperture

  // β per channel at the nominal geometry g (in the plane of measurement).
  std::vector<double> beta(const Bsdf& bsdf, const Geometry& g) const {
    std::vector<double> xs, ws;
    gauss_legendre(nodes, xs, ws);
    const double d2r = std::numbers::pi / 180;
    const double ti = (g.theta_i + profile.arms.incidence_offset_deg) * d2r;
    const double tr = (g.theta_r + profile.arms.receive_offset_deg) * d2r;
    const Vec3 as{-std::sin(ti), 0, std::cos(ti)}, ts{std::cos(ti), 0, std::sin(ti)};
    const Vec3 ar{std::sin(tr), 0, std::cos(tr)}, tr_{std::cos(tr), 0, -std::sin(tr)};
    const Vec3 p{0, 1, 0};
    const double sx = std::tan(0.5 * profile.source.aperture_deg.in_plane * d2r);
    const double sy = std::tan(0.5 * profile.source.aperture_deg.perpendicular * d2r);
    const double rx = std::tan(0.5 * profile.receiver.aperture_deg.in_plane * d2r);
    const double ry = std::tan(0.5 * profile.receiver.aperture_deg.perpendicular * d2r);
    const auto dir = [](const Vec3& a, const Vec3& t, const Vec3& q, double x, double y,
                        double& jac) {
      const Vec3 v{a.x + x * t.x + y * q.x, a.y + x * t.y + y * q.y, a.z + x * t.z + y * q.z};
      const double len = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
      jac = 1 / (len * len * len);
      return Vec3{v.x / len, v.y / len, v.z / len};
    };
    const std::size_t C = bsdf.channels();
    std::vector<double> f(C), num(C, 0.0);
    double den = 0;
    const auto n = static_cast<std::size_t>(nodes);
    for (std::size_t a = 0; a < n; ++a)
      for (std::size_t b = 0; b < n; ++b) {
        double js = 0;
        const Vec3 wi = dir(as, ts, p, sx * xs[a], sy * xs[b], js);
        const double wsrc = ws[a] * ws[b] * js * std::cbrt(js);  // dω · cos γi
        for (std::size_t c = 0; c < n; ++c)
          for (std::size_t d = 0; d < n; ++d) {
            double jr = 0;
            const Vec3 wo = dir(ar, tr_, p, rx * xs[c], ry * xs[d], jr);
            const double wgt = wsrc * ws[c] * ws[d] * jr * std::abs(wo.z);
            bsdf.eval(wi, wo, f);
            for (std::size_t k = 0; k < C; ++k) num[k] += wgt * f[k];
            den += wgt / std::numbers::pi;
          }
      }
    for (double& v : num) v = gain * profile.reference_beta * v / den;
    return num;
  }

  // A synthetic scan: β with Gaussian noise of standard deviation u = rel·β + abs.
  MeasuredData measure(const Bsdf& bsdf, const std::vector<Geometry>& geometries, double rel,
                       double abs, std::uint64_t seed) const {
    MeasuredData d;
    d.wavelengths = bsdf.wavelengths();
    d.source = "ideal instrument";
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> normal;
    for (const auto& g : geometries) {
      MeasuredPoint pt{g, beta(bsdf, g), {}};
      for (double& v : pt.beta) {
        const double u = rel * std::abs(v) + abs;
        pt.u.push_back(u);
        v += u * normal(rng);
      }
      d.points.push_back(std::move(pt));
    }
    return d;
  }
};

// θi = 20, 45, 60°; θr within ±16° of the specular direction, every degree: 99 geometries,
// all with the lit spot inside the viewed area.
inline std::vector<Geometry> specular_scan(double step = 1) {
  std::vector<Geometry> g;
  for (double ti : {20.0, 45.0, 60.0})
    for (double d = -16; d <= 16 + 1e-9; d += step) g.push_back(Geometry::in_plane(ti, ti + d));
  return g;
}

}  // namespace gonio::twin::test
