// oren-nayar — rough diffuse reflector of V-cavities with Gaussian slope deviation σ:
// the qualitative model of Oren & Nayar 1994 ("Generalization of Lambert's Reflectance
// Model", SIGGRAPH '94, eq. 30):
//   f = albedo/π · (A + B max(0, cos(φi − φo)) sin α tan β),
//   A = 1 − 0.5 σ²/(σ² + 0.33),  B = 0.45 σ²/(σ² + 0.09),  α = max(θi, θo), β = min(θi, θo).
// σ = 0 is Lambert. Two-sided; cosine-weighted sampling.
#include <algorithm>
#include <cmath>

#include "gonio/twin/detail/bsdf/model.hpp"
#include "gonio/twin/detail/bsdf/sampling.hpp"

namespace gonio::twin::bsdf {
namespace {

class OrenNayar final : public Lobe {
 public:
  OrenNayar(const Params& p, const WavelengthGrid& grid)
      : Lobe(grid, p.spec()), albedo_(p.spectrum("albedo")), mean_(mean(albedo_)) {
    const double s = p.scalar("sigma") * kDegToRad;
    const double s2 = s * s;
    a_ = 1.0 - 0.5 * s2 / (s2 + 0.33);
    b_ = 0.45 * s2 / (s2 + 0.09);
  }

  void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const override {
    const double g = same_hemisphere(wi, wo) ? shape(wi, wo) * kInvPi : 0.0;
    for (std::size_t c = 0; c < out.size(); ++c) out[c] = albedo_[c] * g;
  }
  std::optional<BsdfSample> sample_wi(const Vec3& wo, double, Vec2 u) const override {
    return sample_cosine(wo, u);
  }
  double pdf(const Vec3& wo, const Vec3& wi) const override { return cosine_pdf(wo, wi); }
  double albedo_hint(const Vec3&) const override { return mean_; }

 private:
  double shape(const Vec3& wi, const Vec3& wo) const {
    const double ci = std::min(1.0, std::abs(wi.z));
    const double co = std::min(1.0, std::abs(wo.z));
    const double si = std::sqrt(std::max(0.0, 1.0 - ci * ci));
    const double so = std::sqrt(std::max(0.0, 1.0 - co * co));
    double cos_dphi = 0;
    if (si > 1e-12 && so > 1e-12)
      cos_dphi = std::max(0.0, (wi.x * wo.x + wi.y * wo.y) / (si * so));
    // sin α tan β with α the larger polar angle (smaller cosine).
    const double sin_alpha = ci > co ? so : si;
    const double tan_beta = ci > co ? si / ci : so / std::max(co, 1e-300);
    return a_ + b_ * cos_dphi * sin_alpha * tan_beta;
  }

  std::vector<double> albedo_;
  double mean_;
  double a_ = 1, b_ = 0;
};

BsdfPtr build_oren_nayar(const Params& p, const WavelengthGrid& grid) {
  return std::make_shared<OrenNayar>(p, grid);
}

}  // namespace

const Registrar kOrenNayarRegistered{{"oren-nayar",
                             {{"albedo", true, 0, 1, false, 0.8, ""},
                              {"sigma", false, 0, 90, false, 20.0, " deg"}},
                             &build_oren_nayar}};

}  // namespace gonio::twin::bsdf
