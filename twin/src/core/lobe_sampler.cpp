// The truncated bivariate-t lobe density (lobe_sampler.hpp).
#include "gonio/twin/detail/core/lobe_sampler.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace gonio::twin::detail {
namespace {

double marginal_cdf(double z) noexcept { return z / std::sqrt(1 + z * z); }

}  // namespace

double t2_conditional_cdf(double t) noexcept { return 0.5 * (t / (1 + t * t) + std::atan(t)); }

// With t = tan(ψ/2), 4·G(t) = ψ + sin ψ, so G(t) = g is ψ + sin ψ = M = 4g on (−π, π):
// Kepler's equation with eccentricity −1. The start is the inverted series at either end,
// ψ = M/2 + M³/96 + M⁵/1920 about 0 and ψ = π − ε, ε = c (1 + c²/60), c = ∛(6 (π − M))
// about π — within 1 % of the root everywhere — and Halley's iteration, cubically
// convergent, takes that to rounding in two steps. A step that would leave [0, π] bisects
// instead (it cannot from these starts; the guard keeps the result bracketed regardless).
double t2_conditional_inverse(double g) noexcept {
  const double m = std::min(std::abs(4 * g), kPi * (1 - 1e-15));
  double psi;
  if (m < 2.2) {
    const double m2 = m * m;
    psi = m * (0.5 + m2 * (1.0 / 96 + m2 / 1920));
  } else {
    const double c = std::cbrt(6 * (kPi - m));
    psi = kPi - c * (1 + c * c / 60);
  }
  double lo = 0, hi = kPi;
  for (int k = 0; k < 40; ++k) {
    const double sn = std::sin(psi), cs = std::cos(psi);
    const double h = psi + sn - m, d1 = 1 + cs;
    (h > 0 ? hi : lo) = psi;
    const double step = 2 * h * d1 / (2 * d1 * d1 + h * sn);
    double next = psi - step;
    if (!(next >= lo && next <= hi)) next = 0.5 * (lo + hi);
    const double moved = std::abs(next - psi);
    psi = next;
    if (moved < 1e-5) break;  // the error after this step is of order moved³
  }
  const double t = std::tan(0.5 * psi);
  return g < 0 ? -t : t;
}

LobeSampler::LobeSampler(Vec2 centre, Vec2 scale, const Aperture& aperture) noexcept
    : c_(centre), s_(scale), ap_(aperture) {
  fa_ = marginal_cdf((-ap_.tx - c_.x) / s_.x);
  df_ = marginal_cdf((ap_.tx - c_.x) / s_.x) - fa_;
  inv_area_scale_ = 1.0 / (s_.x * s_.y * df_);
  // At the x-marginal's median, which lies strictly inside the aperture.
  const double c = fa_ + 0.5 * df_;
  const auto [ay, by] = y_window(std::clamp(c_.x + s_.x * c / std::sqrt((1 - c) * (1 + c)), -ap_.tx, ap_.tx));
  dgy_ = t2_conditional_cdf(by) - t2_conditional_cdf(ay);
}

// The aperture's extent in y at x, in z units: the rectangle's, or the ellipse's chord.
std::pair<double, double> LobeSampler::y_window(double x) const noexcept {
  double h = ap_.ty;
  if (ap_.ellipse) {
    const double r = x / ap_.tx;
    h *= std::sqrt(std::max(0.0, 1 - r * r));
  }
  return {(-h - c_.y) / s_.y, (h - c_.y) / s_.y};
}

LobeSampler::Draw LobeSampler::sample(double u0, double u1) const noexcept {
  const double c = std::clamp(fa_ + u0 * df_, -1 + 1e-16, 1 - 1e-16);
  const double zx = c / std::sqrt((1 - c) * (1 + c));
  const double x = std::clamp(c_.x + s_.x * zx, -ap_.tx, ap_.tx);
  const double k2 = 1 + zx * zx, k = std::sqrt(k2);
  const auto [ay, by] = y_window(x);
  const double ga = t2_conditional_cdf(ay / k), gb = t2_conditional_cdf(by / k);
  if (!(gb > ga)) return {{x, 0}, 0};  // the ellipse's chord at its very end: measure zero
  const double tt = t2_conditional_inverse(ga + u1 * (gb - ga)), q = 1 + tt * tt;
  const double y = std::clamp(c_.y + s_.y * k * tt, c_.y + s_.y * ay, c_.y + s_.y * by);
  return {{x, y}, inv_area_scale_ / (k2 * k2 * q * q * (gb - ga))};
}

double LobeSampler::pdf(Vec2 t) const noexcept {
  if (std::abs(t.x) > ap_.tx || !ap_.contains_tangent(t)) return 0;
  const double zx = (t.x - c_.x) / s_.x, zy = (t.y - c_.y) / s_.y;
  const double k2 = 1 + zx * zx, k = std::sqrt(k2);
  const auto [ay, by] = y_window(t.x);
  const double dg = t2_conditional_cdf(by / k) - t2_conditional_cdf(ay / k);
  if (!(dg > 0)) return 0;
  const double tt = zy / k, q = 1 + tt * tt;
  // (1 + zx²)^(−3/2) / ΔF · (1 + t²)⁻² / (k ΔG), per unit tangent area.
  return inv_area_scale_ / (k2 * k2 * q * q * dg);
}

}  // namespace gonio::twin::detail
