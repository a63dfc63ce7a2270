// dielectric — rough interface between air (above, z > 0) and a medium of index `ior`
// (below), reflecting and transmitting: Walter et al. 2007, "Microfacet Models for
// Refraction through Rough Surfaces", with the GGX distribution.
//
//   reflection   (eq. 20): f_r = F(wo·h) D(h) G2 / (4 |cos θi| |cos θo|),  h ∝ wi + wo
//   transmission (eq. 21): f_t = |wi·h| |wo·h| / (|cos θi| |cos θo|)
//                                · η_i² (1 − F) D(h) G2 / (η_i (wi·h) + η_o (wo·h))²,
//                          h ∝ −(η_i wi + η_o wo) (eq. 16)
// η_i, η_o: indices on the sides of wi (source) and wo (receiver); F is the dielectric
// Fresnel reflectance. G2 is Smith's height-correlated masking-shadowing: 1/(1+Λi+Λo) in
// reflection and the Beta function B(1+Λi, 1+Λo) in transmission (Heitz 2014, JCGT 3(2),
// §6, "height-correlated" form for both configurations).
//
// Radiance convention: Walter's eq. 21 carries η_o² in its numerator, which is the
// radiance just behind the interface (η² times brighter inside the medium). The twin
// predicts what a detector in air sees, so f_t here carries η_i² instead: the radiance
// BTDF multiplied by (η_i/η_o)², i.e. the 1/η² factor of leaving the medium again through
// the sample's back face is included (that face's own Fresnel loss and refraction are not
// modelled). With this choice ∫ f |cos θi| dωi ≤ 1 for every wo, sampling weights are
// G2/G1 ≤ 1, and f(wi, wo)/η_i² = f(wo, wi)/η_o² (generalised reciprocity).
//
// Sampling from the receiver side: a visible normal m of wo (Heitz 2018), then reflection
// with probability F(wo·m), else refraction through m (Walter eqs. 38-40). ior = 1 makes
// the interface vanish: one delta lobe straight through, weight 1.
#include <cmath>

#include "gonio/twin/detail/bsdf/fresnel.hpp"
#include "gonio/twin/detail/bsdf/microfacet.hpp"
#include "gonio/twin/detail/bsdf/model.hpp"
#include "gonio/twin/detail/bsdf/sampling.hpp"

namespace gonio::twin::bsdf {
namespace {

class RoughDielectric final : public Lobe {
 public:
  RoughDielectric(const Params& p, const WavelengthGrid& grid)
      : Lobe(grid, p.spec()), mf_{Distribution::ggx, p.scalar("alpha")}, ior_(p.scalar("ior")) {}

  void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const override {
    const double f = value(wi, wo, nullptr);
    for (auto& v : out) v = f;
  }

  std::optional<BsdfSample> sample_wi(const Vec3& wo_in, double u_lobe, Vec2 u) const override {
    if (wo_in.z == 0 || ior_ == 1.0) return std::nullopt;
    const bool below = wo_in.z < 0;
    const Vec3 wo = below ? flip_z(wo_in) : wo_in;
    const double e = below ? 1.0 / ior_ : ior_;  // η beyond the interface / η on wo's side
    const Vec3 m = mf_.sample_visible(wo, u);
    const double c = dot(wo, m);
    if (c <= 0) return std::nullopt;
    Vec3 wi;
    if (u_lobe < fresnel_dielectric(c, e)) {
      wi = reflect(wo, m);
      if (wi.z <= 0) return std::nullopt;
    } else {
      const double sin2_t = (1.0 - c * c) / (e * e);
      if (sin2_t >= 1.0) return std::nullopt;
      const double cos_t = std::sqrt(1.0 - sin2_t);
      wi = -wo / e + (c / e - cos_t) * m;
      if (wi.z >= 0) return std::nullopt;
      wi = normalize(wi);
    }
    if (below) wi = flip_z(wi);
    const double p = pdf(wo_in, wi);
    if (!(p > 0)) return std::nullopt;
    return BsdfSample{wi, p};
  }

  double pdf(const Vec3& wo, const Vec3& wi) const override {
    double p = 0;
    (void)value(wi, wo, &p);
    return p;
  }

  void delta_lobes(const Vec3& wo, std::vector<DeltaLobe>& out) const override {
    out.clear();
    if (ior_ == 1.0 && wo.z != 0) out.push_back({-wo, std::vector<double>(channels(), 1.0)});
  }
  bool has_delta() const noexcept override { return ior_ == 1.0; }
  double albedo_hint(const Vec3&) const override { return ior_ == 1.0 ? 0.0 : 1.0; }

 private:
  // f(wi, wo) (the same on every channel); writes the sampling density to *pdf if asked.
  double value(const Vec3& wi_in, const Vec3& wo_in, double* pdf) const {
    if (pdf != nullptr) *pdf = 0;
    if (wi_in.z == 0 || wo_in.z == 0 || ior_ == 1.0) return 0;
    const bool below = wo_in.z < 0;
    const Vec3 wo = below ? flip_z(wo_in) : wo_in;
    const Vec3 wi = below ? flip_z(wi_in) : wi_in;
    const double e = below ? 1.0 / ior_ : ior_;
    if (wi.z > 0) {
      const Vec3 h = normalize(wi + wo);
      const double F = fresnel_dielectric(dot(wo, h), e);
      const double d = mf_.D(h);
      if (pdf != nullptr) *pdf = F * mf_.G1(wo) * d / (4.0 * wo.z);
      return F * d * mf_.G2(wi, wo) / (4.0 * wi.z * wo.z);
    }
    // Transmission, in units of wo's index: η_o = 1, η_i = e.
    Vec3 h = -(wo + e * wi);
    const double len = length(h);
    if (!(len > 0)) return 0;
    h = h / len;
    if (h.z < 0) h = -h;
    const double oh = dot(wo, h);
    const double ih = dot(wi, h);
    if (oh <= 0 || ih >= 0) return 0;  // a microfacet must face wo and be crossed by wi
    const double denom = e * ih + oh;
    if (denom == 0) return 0;
    const double F = fresnel_dielectric(oh, e);
    const double d = mf_.D(h);
    const double jac = e * e * std::abs(ih) / (denom * denom);  // |∂h/∂wi| (Walter eq. 17)
    if (pdf != nullptr) *pdf = (1.0 - F) * mf_.G1(wo) * oh * d / wo.z * jac;
    const double li = mf_.lambda(wi);
    const double lo = mf_.lambda(wo);
    if (!std::isfinite(li) || !std::isfinite(lo)) return 0;
    const double g2 = std::exp(std::lgamma(1.0 + li) + std::lgamma(1.0 + lo) - std::lgamma(2.0 + li + lo));
    return std::abs(ih) * oh / (-wi.z * wo.z) * e * e * (1.0 - F) * d * g2 / (denom * denom);
  }

  Microfacet mf_;
  double ior_;
};

BsdfPtr build_dielectric(const Params& p, const WavelengthGrid& grid) {
  return std::make_shared<RoughDielectric>(p, grid);
}

}  // namespace

const Registrar kDielectricRegistered{{"dielectric",
                             {{"alpha", false, 0.001, 1, false, 0.1, ""},
                              {"ior", false, 1, 4, false, 1.5, ""}},
                             &build_dielectric}};

}  // namespace gonio::twin::bsdf
