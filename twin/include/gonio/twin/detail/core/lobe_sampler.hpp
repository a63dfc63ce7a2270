// A glossy lobe's shape, truncated to a rectangular aperture, as a sampling density.
//
// A microfacet lobe seen through an aperture narrower than itself is, for a fixed receiver
// direction, a function of the source direction's offset from the mirror direction. For GGX
// that function is, in the half-vector's slope space, D ∝ (1 + |s|²/α²)⁻² — a bivariate
// Student t with two degrees of freedom — and the map from the aperture's tangent plane to
// slope space is close to linear over the lobe. So in normalised tangent coordinates
// z = (t − c) / s (centre c the mirror direction, scales s per axis) the lobe is close to
//
//   q(z) = (1 + zx² + zy²)⁻².
//
// Its marginal in zx is ∝ (1 + zx²)^(−3/2), whose integral zx / √(1 + zx²) inverts in closed
// form, and its conditional in zy given zx is ∝ (1 + t²)⁻² with t = zy / √(1 + zx²), whose
// integral G(t) = (t / (1 + t²) + atan t) / 2 inverts by a Kepler-like equation. Drawing zx
// from the marginal truncated to the aperture, then zy from the conditional truncated to it,
// gives every draw inside the aperture, moving continuously with its uniforms (no rejection),
// with density p(z) = q(z) / (ΔF · ΔG(zx)): the lobe itself up to a factor that depends on zx
// only, through how much of the conditional the aperture cuts away. The estimator's weight
// f / p is then nearly constant over the lobe, and smooth — what randomised QMC needs.
#pragma once

#include <utility>

#include "gonio/twin/detail/core/optics.hpp"
#include "gonio/twin/vec.hpp"

namespace gonio::twin::detail {

// G(t) = ∫₀ᵗ (1 + x²)⁻² dx, and its inverse on (−π/4, π/4).
double t2_conditional_cdf(double t) noexcept;
double t2_conditional_inverse(double g) noexcept;

class LobeSampler {
 public:
  // `centre` and `scale` in tangent units; scales must be positive. For an elliptical
  // aperture the conditional is truncated to the ellipse's chord at the drawn x.
  LobeSampler(Vec2 centre, Vec2 scale, const Aperture& aperture) noexcept;

  struct Draw {
    Vec2 t;      // tangent-plane point, always inside the aperture
    double pdf;  // its density per unit tangent area (0 only on a set of measure zero)
  };
  // The draw for uniforms (u0, u1) in [0, 1)².
  Draw sample(double u0, double u1) const noexcept;
  // Density per unit tangent area at t (0 outside the aperture).
  double pdf(Vec2 t) const noexcept;
  // False when the aperture lies so far in the lobe's tail that the density underflows.
  bool usable() const noexcept { return df_ > 1e-9 && dgy_ > 1e-9; }

 private:
  std::pair<double, double> y_window(double x) const noexcept;

  Vec2 c_, s_;
  Aperture ap_;
  double fa_ = 0, df_ = 0;         // F(ax) and F(bx) − F(ax), F(z) = z / √(1 + z²)
  double inv_area_scale_ = 0;      // 1 / (sx · sy · ΔF)
  double dgy_ = 0;                 // ΔG of the y window at the x-marginal's median
};

}  // namespace gonio::twin::detail
