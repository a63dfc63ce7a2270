// coat — the specular reflection of a clear coat or gloss layer, for sums such as
// `lambert:albedo=0.5+coat:alpha=0.05,ior=1.5`: a GGX microfacet BRDF (Walter et al. 2007
// eq. 20, height-correlated Smith G2) with the dielectric Fresnel reflectance of `ior`.
// Reflection only (what the coat transmits is left to the other lobes: a sum does not
// attenuate them). Two-sided; sampled through the visible normals of wo (the reflection
// lobe it shares with `conductor`, microfacet.hpp).
#include "gonio/twin/detail/bsdf/fresnel.hpp"
#include "gonio/twin/detail/bsdf/microfacet.hpp"
#include "gonio/twin/detail/bsdf/model.hpp"

namespace gonio::twin::bsdf {
namespace {

class Coat final : public Lobe {
 public:
  Coat(const Params& p, const WavelengthGrid& grid)
      : Lobe(grid, p.spec()), mf_{Distribution::ggx, p.scalar("alpha")}, ior_(p.scalar("ior")) {}

  void eval(const Vec3& wi_in, const Vec3& wo_in, std::span<double> out) const override {
    double f = 0;
    if (const auto fr = reflection_frame(wi_in, wo_in))
      f = fresnel_dielectric(dot(fr->wi, fr->h), ior_) * mf_.D(fr->h) * mf_.G2(fr->wi, fr->wo) /
          (4.0 * fr->wi.z * fr->wo.z);
    for (auto& v : out) v = f;
  }

  std::optional<BsdfSample> sample_wi(const Vec3& wo, double, Vec2 u) const override {
    return sample_reflection(mf_, wo, u);
  }

  double pdf(const Vec3& wo, const Vec3& wi) const override { return reflection_pdf(mf_, wo, wi); }

  double albedo_hint(const Vec3& wo) const override {
    return fresnel_dielectric(abs_cos_theta(wo), ior_);
  }

 private:
  Microfacet mf_;
  double ior_;
};

BsdfPtr build_coat(const Params& p, const WavelengthGrid& grid) {
  return std::make_shared<Coat>(p, grid);
}

}  // namespace

const Registrar kCoatRegistered{{"coat",
                             {{"alpha", false, 0.001, 1, false, 0.05, ""},
                              {"ior", false, 1, 4, false, 1.5, ""}},
                             &build_coat}};

}  // namespace gonio::twin::bsdf
