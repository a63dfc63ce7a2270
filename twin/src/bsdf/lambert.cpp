// lambert — ideal diffuse reflector: f = albedo / π (Lambert 1760), the reference white's
// default BSDF. Two-sided; sampled with the cosine-weighted density, which is exactly
// proportional to f |cos θi|.
#include "gonio/twin/detail/bsdf/model.hpp"
#include "gonio/twin/detail/bsdf/sampling.hpp"

namespace gonio::twin::bsdf {
namespace {

class Lambert final : public Lobe {
 public:
  Lambert(const Params& p, const WavelengthGrid& grid)
      : Lobe(grid, p.spec()), albedo_(p.spectrum("albedo")), mean_(mean(albedo_)) {}

  void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const override {
    const bool lit = same_hemisphere(wi, wo);
    for (std::size_t c = 0; c < out.size(); ++c) out[c] = lit ? albedo_[c] * kInvPi : 0.0;
  }
  std::optional<BsdfSample> sample_wi(const Vec3& wo, double, Vec2 u) const override {
    return sample_cosine(wo, u);
  }
  double pdf(const Vec3& wo, const Vec3& wi) const override { return cosine_pdf(wo, wi); }
  double albedo_hint(const Vec3&) const override { return mean_; }

 private:
  std::vector<double> albedo_;
  double mean_;
};

BsdfPtr build_lambert(const Params& p, const WavelengthGrid& grid) {
  return std::make_shared<Lambert>(p, grid);
}

}  // namespace

const Registrar kLambertRegistered{{"lambert", {{"albedo", true, 0, 1, false, 1.0, ""}}, &build_lambert}};

}  // namespace gonio::twin::bsdf
