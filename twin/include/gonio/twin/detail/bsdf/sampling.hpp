// Small sampling helpers shared by the analytic models: cosine-weighted hemisphere (and
// the diffuse models' sampler built on it), inverse error function.
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>

#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/vec.hpp"

namespace gonio::twin::bsdf {

// Inverse of erf on (−1, 1): Winitzki's closed-form approximation ("A handy approximation
// for the error function and its inverse", 2008, a = 0.147) polished by Newton steps on
// std::erf. Arguments are clamped just inside ±1.
inline double erf_inv(double y) noexcept {
  constexpr double kLimit = 1.0 - 1e-15;
  y = std::clamp(y, -kLimit, kLimit);
  constexpr double a = 0.147;
  const double ln = std::log((1.0 - y) * (1.0 + y));
  const double t = 2.0 / (kPi * a) + ln / 2.0;
  double x = std::copysign(std::sqrt(std::sqrt(t * t - ln / a) - t), y);
  for (int i = 0; i < 3; ++i) {
    const double d = 2.0 / std::sqrt(kPi) * std::exp(-x * x);
    if (d <= 0) break;
    x -= (std::erf(x) - y) / d;
  }
  return x;
}

// Cosine-weighted direction on the +z hemisphere (density cos θ / π): Malley's method on
// Shirley & Chiu's concentric disk mapping (1997).
inline Vec3 sample_cosine_hemisphere(Vec2 u) noexcept {
  const double ox = 2 * u.x - 1;
  const double oy = 2 * u.y - 1;
  double r = 0;
  double phi = 0;
  if (ox != 0 || oy != 0) {
    if (std::abs(ox) > std::abs(oy)) {
      r = ox;
      phi = (kPi / 4) * (oy / ox);
    } else {
      r = oy;
      phi = kPi / 2 - (kPi / 4) * (ox / oy);
    }
  }
  const double x = r * std::cos(phi);
  const double y = r * std::sin(phi);
  return {x, y, std::sqrt(std::max(0.0, 1.0 - x * x - y * y))};
}

// Mirror of w through the sample plane (z → −z): reflection models are two-sided, and
// each evaluates in the hemisphere of wo after this flip.
constexpr Vec3 flip_z(const Vec3& w) noexcept { return {w.x, w.y, -w.z}; }

// Density of a cosine-weighted wi in the hemisphere of wo: |cos θi| / π, zero across it.
inline double cosine_pdf(const Vec3& wo, const Vec3& wi) noexcept {
  return same_hemisphere(wi, wo) ? abs_cos_theta(wi) * kInvPi : 0.0;
}

// A cosine-weighted wi in the hemisphere of wo, the sampler of the diffuse models (lambert,
// oren-nayar); none at grazing wo or on the disk's rim.
inline std::optional<BsdfSample> sample_cosine(const Vec3& wo, Vec2 u) noexcept {
  if (wo.z == 0) return std::nullopt;
  Vec3 wi = sample_cosine_hemisphere(u);
  if (wi.z <= 0) return std::nullopt;
  if (wo.z < 0) wi = flip_z(wi);
  return BsdfSample{wi, cosine_pdf(wo, wi)};
}

}  // namespace gonio::twin::bsdf
