// coat — the specular reflection of a clear coat or gloss layer, for sums such as
// `lambert:albedo=0.5+coat:alpha=0.05,ior=1.5`: a GGX microfacet BRDF (Walter et al. 2007
// eq. 20, height-correlated Smith G2) with the dielectric Fresnel reflectance of `ior`.
// Reflection only (what the coat transmits is left to the other lobes: a sum does not
// attenuate them). Two-sided; sampled through the visible normals of wo.
#include "bsdf/fresnel.hpp"
#include "bsdf/microfacet.hpp"
#include "bsdf/model.hpp"
#include "bsdf/sampling.hpp"

namespace gonio::twin::bsdf {
namespace {

class Coat final : public Lobe {
 public:
  Coat(const Params& p, const WavelengthGrid& grid)
      : Lobe(grid, p.spec()), mf_{Distribution::ggx, p.scalar("alpha")}, ior_(p.scalar("ior")) {}

  void eval(const Vec3& wi_in, const Vec3& wo_in, std::span<double> out) const override {
    double f = 0;
    if (same_hemisphere(wi_in, wo_in)) {
      const Vec3 wi = wo_in.z < 0 ? flip_z(wi_in) : wi_in;
      const Vec3 wo = wo_in.z < 0 ? flip_z(wo_in) : wo_in;
      const Vec3 h = normalize(wi + wo);
      f = fresnel_dielectric(dot(wi, h), ior_) * mf_.D(h) * mf_.G2(wi, wo) / (4.0 * wi.z * wo.z);
    }
    for (auto& v : out) v = f;
  }

  std::optional<BsdfSample> sample_wi(const Vec3& wo_in, double, Vec2 u) const override {
    if (wo_in.z == 0) return std::nullopt;
    const Vec3 wo = wo_in.z < 0 ? flip_z(wo_in) : wo_in;
    Vec3 wi = reflect(wo, mf_.sample_visible(wo, u));
    if (wi.z <= 0) return std::nullopt;
    if (wo_in.z < 0) wi = flip_z(wi);
    const double p = pdf(wo_in, wi);
    if (!(p > 0)) return std::nullopt;
    return BsdfSample{wi, p};
  }

  double pdf(const Vec3& wo_in, const Vec3& wi_in) const override {
    if (!same_hemisphere(wi_in, wo_in)) return 0.0;
    const Vec3 wi = wo_in.z < 0 ? flip_z(wi_in) : wi_in;
    const Vec3 wo = wo_in.z < 0 ? flip_z(wo_in) : wo_in;
    return mf_.G1(wo) * mf_.D(normalize(wi + wo)) / (4.0 * wo.z);
  }

  double albedo_hint(const Vec3& wo) const override {
    return fresnel_dielectric(abs_cos_theta(wo), ior_);
  }

 private:
  Microfacet mf_;
  double ior_;
};

BsdfPtr build(const Params& p, const WavelengthGrid& grid) {
  return std::make_shared<Coat>(p, grid);
}

}  // namespace

const ModelInfo& coat_model() {
  static const ModelInfo info{"coat",
                              {{"alpha", false, 0.001, 1, false, 0.05, ""},
                               {"ior", false, 1, 4, false, 1.5, ""}},
                              &build};
  return info;
}

}  // namespace gonio::twin::bsdf
