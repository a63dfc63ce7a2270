// conductor — rough metal: a Cook-Torrance microfacet BRDF (Walter et al. 2007,
// "Microfacet Models for Refraction through Rough Surfaces", eq. 20)
//   f = F(wi·h) D(h) G2(wi, wo) / (4 |cos θi| |cos θo|),  h = (wi + wo)/|wi + wo|
// with the GGX (Trowbridge-Reitz) distribution, the height-correlated Smith G2 and the
// complex Fresnel reflectance of η + i k per channel. Two-sided. Sampled through the
// visible normals of wo (the Fresnel term is left out of the density, which is the same
// for every channel): pdf = D_wo(h) / (4 wo·h) = G1(wo) D(h) / (4 cos θo) (Heitz 2018 §2).
// The `beckmann` model is this class with the Beckmann distribution.
#include "bsdf/conductor.hpp"

#include "gonio/twin/detail/bsdf/fresnel.hpp"

namespace gonio::twin::bsdf {
namespace {

class RoughConductor final : public Lobe {
 public:
  RoughConductor(const Params& p, const WavelengthGrid& grid, Distribution d)
      : Lobe(grid, p.spec()),
        mf_{d, p.scalar("alpha")},
        eta_(p.spectrum("eta")),
        k_(p.spectrum("k")) {}

  void eval(const Vec3& wi_in, const Vec3& wo_in, std::span<double> out) const override {
    for (auto& v : out) v = 0.0;
    const auto fr = reflection_frame(wi_in, wo_in);
    if (!fr) return;
    const double common = mf_.D(fr->h) * mf_.G2(fr->wi, fr->wo) / (4.0 * fr->wi.z * fr->wo.z);
    if (!(common > 0)) return;
    const double cos_h = dot(fr->wi, fr->h);
    // Spectrally flat stretches of η and k (common in specs) reuse the previous channel.
    for (std::size_t c = 0; c < out.size(); ++c)
      out[c] = c > 0 && eta_[c] == eta_[c - 1] && k_[c] == k_[c - 1]
                   ? out[c - 1]
                   : common * fresnel_conductor(cos_h, eta_[c], k_[c]);
  }

  std::optional<BsdfSample> sample_wi(const Vec3& wo, double, Vec2 u) const override {
    return sample_reflection(mf_, wo, u);
  }

  double pdf(const Vec3& wo, const Vec3& wi) const override { return reflection_pdf(mf_, wo, wi); }

  double albedo_hint(const Vec3& wo) const override {
    double s = 0;
    for (std::size_t c = 0; c < eta_.size(); ++c)
      s += fresnel_conductor(abs_cos_theta(wo), eta_[c], k_[c]);
    return s / static_cast<double>(eta_.size());
  }

 private:
  Microfacet mf_;
  std::vector<double> eta_, k_;
};

BsdfPtr build_conductor(const Params& p, const WavelengthGrid& grid) {
  return make_rough_conductor(p, grid, Distribution::ggx);
}

}  // namespace

BsdfPtr make_rough_conductor(const Params& p, const WavelengthGrid& grid, Distribution d) {
  return std::make_shared<RoughConductor>(p, grid, d);
}

std::vector<ParamInfo> conductor_params() {
  // Default η, k: aluminium near 550 nm (Rakić 1995, Applied Optics 34(22)), n ≈ 0.96,
  // k ≈ 6.69: a neutral, bright metal.
  return {{"alpha", false, 0.001, 1, false, 0.1, ""},
          {"eta", true, 0, 10, true, 0.96, ""},
          {"k", true, 0, 20, false, 6.69, ""}};
}

const Registrar kConductorRegistered{{"conductor", conductor_params(), &build_conductor}};

}  // namespace gonio::twin::bsdf
