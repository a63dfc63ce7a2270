// Visible-normal sampling for the GGX and Beckmann distributions.
//
// Both work in the "stretched" configuration where the roughness is 1 (slopes scale
// linearly with α): GGX by Heitz 2018 ("Sampling the GGX Distribution of Visible Normals",
// JCGT 7(4)), which maps a uniform disk onto the projected hemisphere of the stretched
// direction; Beckmann by Heitz & d'Eon 2014 ("Importance Sampling Microfacet-Based BSDFs
// using the Distribution of Visible Normals", §4 and appendix), which inverts the CDF of
// the visible slope along the incident azimuth and draws the other slope from a Gaussian.
// Then the two-sided reflection lobe built on them (microfacet.hpp).
#include "gonio/twin/detail/bsdf/microfacet.hpp"

#include <algorithm>

#include "gonio/twin/detail/bsdf/sampling.hpp"

namespace gonio::twin::bsdf {
namespace {

Vec3 sample_ggx_visible(const Vec3& w, double alpha, Vec2 u) noexcept {
  const Vec3 vh = normalize(Vec3{alpha * w.x, alpha * w.y, w.z});
  const double lensq = vh.x * vh.x + vh.y * vh.y;
  const Vec3 t1 = lensq > 0 ? Vec3{-vh.y, vh.x, 0} / std::sqrt(lensq) : Vec3{1, 0, 0};
  const Vec3 t2 = cross(vh, t1);
  const double r = std::sqrt(u.x);
  const double phi = 2 * kPi * u.y;
  const double p1 = r * std::cos(phi);
  double p2 = r * std::sin(phi);
  const double s = 0.5 * (1.0 + vh.z);
  p2 = (1.0 - s) * std::sqrt(std::max(0.0, 1.0 - p1 * p1)) + s * p2;
  const Vec3 nh = p1 * t1 + p2 * t2 + std::sqrt(std::max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh;
  return normalize(Vec3{alpha * nh.x, alpha * nh.y, std::max(1e-12, nh.z)});
}

// Visible slope along the incident azimuth for a Beckmann surface of unit roughness seen
// at cot θ = mu: density ∝ (mu − x) exp(−x²) on x < mu, whose CDF (unnormalised) is
// C(x) = mu √π/2 · erfc(−x) + exp(−x²)/2. Solved by safeguarded Newton iteration.
double sample_beckmann_slope_x(double mu, double u) noexcept {
  if (mu > 1e6) return erf_inv(2 * u - 1);  // normal incidence: plain Gaussian slopes
  const double k = mu * std::sqrt(kPi) / 2;
  const auto cdf = [k](double x) { return k * std::erfc(-x) + 0.5 * std::exp(-x * x); };
  const double target = u * cdf(mu);
  double lo = -9.0;
  double hi = mu;
  if (target <= cdf(lo)) return lo;
  double x = std::clamp(erf_inv(2 * u - 1), lo, hi);
  for (int it = 0; it < 100; ++it) {
    const double c = cdf(x) - target;
    if (c > 0) hi = x; else lo = x;
    const double d = (mu - x) * std::exp(-x * x);
    double next = d > 0 ? x - c / d : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    const double step = std::abs(next - x);
    x = next;
    if (step < 1e-13 * std::max(1.0, std::abs(x)) || hi - lo < 1e-14) break;
  }
  return x;
}

Vec3 sample_beckmann_visible(const Vec3& w, double alpha, Vec2 u) noexcept {
  const Vec3 ws = normalize(Vec3{alpha * w.x, alpha * w.y, w.z});
  const double sin_t = std::sqrt(ws.x * ws.x + ws.y * ws.y);
  const double mu = sin_t > 0 ? ws.z / sin_t : 1e300;
  const double cos_p = sin_t > 0 ? ws.x / sin_t : 1.0;
  const double sin_p = sin_t > 0 ? ws.y / sin_t : 0.0;
  const double x = sample_beckmann_slope_x(mu, u.x);
  const double y = erf_inv(2 * u.y - 1);
  // Rotate into the incident azimuth, unstretch, and turn slopes into a normal.
  const double sx = alpha * (cos_p * x - sin_p * y);
  const double sy = alpha * (sin_p * x + cos_p * y);
  return normalize(Vec3{-sx, -sy, 1.0});
}

}  // namespace

Vec3 Microfacet::sample_visible(const Vec3& w, Vec2 u) const noexcept {
  return kind == Distribution::ggx ? sample_ggx_visible(w, alpha, u)
                                   : sample_beckmann_visible(w, alpha, u);
}

std::optional<ReflectionFrame> reflection_frame(const Vec3& wi_in, const Vec3& wo_in) noexcept {
  if (!same_hemisphere(wi_in, wo_in)) return std::nullopt;
  const Vec3 wi = wo_in.z < 0 ? flip_z(wi_in) : wi_in;
  const Vec3 wo = wo_in.z < 0 ? flip_z(wo_in) : wo_in;
  return ReflectionFrame{wi, wo, normalize(wi + wo)};
}

double reflection_pdf(const Microfacet& mf, const Vec3& wo, const Vec3& wi) noexcept {
  const auto f = reflection_frame(wi, wo);
  if (!f) return 0.0;
  return mf.G1(f->wo) * mf.D(f->h) / (4.0 * f->wo.z);
}

std::optional<BsdfSample> sample_reflection(const Microfacet& mf, const Vec3& wo_in, Vec2 u) noexcept {
  if (wo_in.z == 0) return std::nullopt;
  const Vec3 wo = wo_in.z < 0 ? flip_z(wo_in) : wo_in;
  Vec3 wi = reflect(wo, mf.sample_visible(wo, u));
  if (wi.z <= 0) return std::nullopt;
  if (wo_in.z < 0) wi = flip_z(wi);
  const double p = reflection_pdf(mf, wo_in, wi);
  if (!(p > 0)) return std::nullopt;
  return BsdfSample{wi, p};
}

}  // namespace gonio::twin::bsdf
