// A BSDF seen by the renderer: its spectral channels projected onto the display's colour
// channels (X, Y, Z, or Y alone), its sampler, and its directional albedo per θo.
//
// Every light of the scene has the spectrum of D65, so a pixel's XYZ is the integral of
// Σ_c w_k[c]·f_c: projecting f once per evaluation is exact. A TabulatedBsdf's table is
// projected once at set-up instead (multilinear interpolation commutes with a fixed
// linear combination of channels), which makes its evaluation several times cheaper than
// interpolating every wavelength.
//
// The albedo A(θo) = E[f·cos θi / p] of the BSDF's own sampler (reflection only) and the
// lobe's first moment M(θo) = E[f·cos θi / p · ωi] are the expectations the renderer's
// control variate needs (twin/rendering.md); they are tabulated on θo nodes with
// randomised QMC (wo in the x–z plane, where M has no y component) and interpolated
// linearly. Only an isotropic BSDF has an
// albedo that depends on θo alone: for an anisotropic table `isotropic()` is false and the
// renderer does without the control variate.
#pragma once

#include <array>
#include <optional>
#include <vector>

#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/tabulated.hpp"

namespace gonio::twin::render {

using Color = std::array<double, 3>;  // X, Y, Z (Y alone in channel 1 for grey renders)

class ColorBsdf {
 public:
  // `colour` false: channel 1 (Y) only, the others left 0. With `moments` the albedo and
  // moment tables are built, on `threads` threads (0: hardware concurrency).
  ColorBsdf(const Bsdf& bsdf, bool color, bool moments, unsigned threads);

  // Projected f(wi, wo) for reflection (wi.z > 0, wo.z > 0; 0 otherwise).
  Color eval(const Vec3& wi, const Vec3& wo) const;
  std::optional<BsdfSample> sample(const Vec3& wo, double u_lobe, Vec2 u) const {
    return bsdf_.sample_wi(wo, u_lobe, u);
  }
  double pdf(const Vec3& wo, const Vec3& wi) const { return bsdf_.pdf(wo, wi); }
  bool has_delta() const noexcept { return bsdf_.has_delta(); }
  // Delta lobes above the surface, projected.
  void delta(const Vec3& wo, std::vector<std::pair<Vec3, Color>>& out) const;

  bool isotropic() const noexcept { return isotropic_; }
  bool has_moments() const noexcept { return !nodes_.empty(); }
  // A(wo) and M(wo) (local frame) of the sampler, projected.
  struct Moments {
    Color albedo;
    std::array<Vec3, 3> moment;
  };
  Moments moments(const Vec3& wo) const;

  // The colour weights per spectral channel of the BSDF (for tests).
  const std::array<std::vector<double>, 3>& weights() const noexcept { return w_; }

 private:
  void build_albedo(unsigned threads);

  const Bsdf& bsdf_;
  bool color_;
  std::array<std::vector<double>, 3> w_;
  std::vector<BsdfTable> projected_;  // X, Y, Z as three channels; TabulatedBsdf BRDFs only
  bool isotropic_ = true;
  struct Node {
    Color a, mx, mz;
  };
  std::vector<Node> nodes_;           // at θo = k·90°/(n − 1)
};

}  // namespace gonio::twin::render
