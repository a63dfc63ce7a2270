// Microfacet distributions for the rough models: GGX (Trowbridge-Reitz) and Beckmann.
//
// Isotropic distributions of normals m in the local frame (normal +z), each with its
// normal distribution D(m), Smith's Λ(w), the masking G1 and the height-correlated
// masking-shadowing G2, and exact sampling of the distribution of visible normals
// D_w(m) = G1(w) max(0, w·m) D(m) / cos θw (Heitz 2014, "Understanding the Masking-
// Shadowing Function in Microfacet-Based BRDFs", JCGT 3(2), eqs. 2, 38, 99). Visible-normal
// sampling keeps narrow lobes (α down to 0.001) and grazing directions well sampled.
//
// Also the two-sided reflection lobe that `conductor`, `beckmann` and `coat` share: the
// frame (wi, wo mirrored to wo's side, their half vector), sampling wi by reflecting wo
// about a visible normal, and that sampler's density G1(wo) D(h) / (4 cos θo) (Heitz 2018
// §2). Each model multiplies D G2 / (4 cos θi cos θo) by its own Fresnel term.
#pragma once

#include <cmath>
#include <limits>
#include <optional>

#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/vec.hpp"

namespace gonio::twin::bsdf {

enum class Distribution { ggx, beckmann };

struct Microfacet {
  Distribution kind = Distribution::ggx;
  double alpha = 0.1;  // RMS-slope-like roughness; α = 0.001 is nearly a mirror

  // D(m) in sr⁻¹ with ∫ D(m) cos θm dm = 1; zero for m below the surface.
  double D(const Vec3& m) const noexcept {
    if (m.z <= 0) return 0;
    const double a2 = alpha * alpha;
    const double sin2 = m.x * m.x + m.y * m.y;
    const double cos2 = m.z * m.z;
    if (kind == Distribution::ggx) {
      // Walter et al. 2007 eq. 33, written as α² / (π (sin²θ + α² cos²θ)²) so that it
      // stays accurate for tiny α near the peak.
      const double t = sin2 + a2 * cos2;
      return a2 / (kPi * t * t);
    }
    // Beckmann: Walter et al. 2007 eq. 25.
    return std::exp(-sin2 / (cos2 * a2)) / (kPi * a2 * cos2 * cos2);
  }

  // Smith Λ(w) for the surface normal +z; uses |cos θ| so it serves both hemispheres.
  double lambda(const Vec3& w) const noexcept {
    const double cos2 = w.z * w.z;
    if (cos2 == 0) return std::numeric_limits<double>::infinity();
    const double tan2 = (w.x * w.x + w.y * w.y) / cos2;
    if (kind == Distribution::ggx) {
      // Heitz 2014 eq. 86: (−1 + sqrt(1 + α² tan²θ)) / 2, rearranged against cancellation.
      const double s = alpha * alpha * tan2;
      return s / (2.0 * (1.0 + std::sqrt(1.0 + s)));
    }
    // Heitz 2014 eq. 72 with a = 1 / (α tan θ): (erf(a) − 1)/2 + exp(−a²) / (2 a √π).
    if (tan2 == 0) return 0;
    const double a = 1.0 / (alpha * std::sqrt(tan2));
    if (a > 25) return 0;  // both terms below 1e-270
    const double l = -0.5 * std::erfc(a) + std::exp(-a * a) / (2.0 * a * std::sqrt(kPi));
    return l > 0 ? l : 0;
  }

  double G1(const Vec3& w) const noexcept { return 1.0 / (1.0 + lambda(w)); }
  // Height-correlated masking-shadowing (Heitz 2014 eq. 99); the caller checks that wi
  // and wo are on the visible sides of m.
  double G2(const Vec3& wi, const Vec3& wo) const noexcept {
    return 1.0 / (1.0 + lambda(wi) + lambda(wo));
  }

  // Density of visible normals D_w(m) for w.z > 0 (Heitz 2014 eq. 38).
  double visible_pdf(const Vec3& w, const Vec3& m) const noexcept {
    const double wm = dot(w, m);
    if (w.z <= 0 || wm <= 0) return 0;
    return G1(w) * wm * D(m) / w.z;
  }

  // Draws m from D_w(m) for w.z > 0, u ∈ [0,1)².
  Vec3 sample_visible(const Vec3& w, Vec2 u) const noexcept;
};

// wi and wo of a two-sided reflection lobe mirrored into wo's hemisphere (so wo.z > 0 and
// wi.z > 0), with the half vector h = (wi + wo)/|wi + wo|.
struct ReflectionFrame {
  Vec3 wi, wo, h;
};

// The frame of (wi, wo); none when they are not strictly on the same side of the surface.
std::optional<ReflectionFrame> reflection_frame(const Vec3& wi, const Vec3& wo) noexcept;

// Density of sample_reflection: G1(wo) D(h) / (4 |cos θo|) when wi and wo are on the same
// side, else 0.
double reflection_pdf(const Microfacet& mf, const Vec3& wo, const Vec3& wi) noexcept;

// wi from reflecting wo about a visible normal of wo, on wo's side of the surface, with
// its density; none for grazing wo, a reflection below the surface or a zero density.
std::optional<BsdfSample> sample_reflection(const Microfacet& mf, const Vec3& wo, Vec2 u) noexcept;

}  // namespace gonio::twin::bsdf
