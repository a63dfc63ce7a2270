// plastic — a coated diffuser, as most paints, plastics and lacquered panels are: a spectral
// Lambertian base (albedo ρ) under a rough dielectric interface (GGX roughness α, index η),
// optionally hazy (a share h of the interface's microfacets from a wider GGX lobe α_h: a
// sharp peak on a wide halo).
//
//   f = f_s + f_d
//   f_s = (1 − h) f_α + h f_αh,   f_a = F(wi·m, η) D_a(m) G2_a / (4 cos θi cos θo)  (as `coat`)
//   f_d = ρ T(θi) T(θo) / (π η² (1 − ρ F_in)),   T(θ) = 1 − R(θ)
//
// R(θ) is the interface's directional albedo ∫ f_s cos θi dωi, integrated at construction:
// the light the interface does not reflect enters the coat (Kelemen & Szirmay-Kalos 2001,
// "A microfacet based coupled specular-matte BRDF model with importance sampling", the
// coupling 1 − albedo in and out). Inside, the base's light meets the interface from below;
// by étendue a share e = (1 − R̄)/η² escapes (R̄ = ∫ R(θ) 2 cos θ sin θ dθ, the
// hemispherical average), F_in = 1 − e goes back to the base, and the base and the
// interface inter-reflect as a geometric series: ρ e / (1 − ρ F_in) in total (the layering
// of Weidlich & Wilkie 2007, "Arbitrarily layered micro-facet surfaces", and the
// `nonlinear` diffuse term of Mitsuba's `roughplastic`).
//
// Energy is conserved by construction: the albedo at θ is R(θ) + T(θ) ρ e / (1 − ρ(1 − e))
// ≤ R(θ) + T(θ) = 1. f_d is symmetric in θi and θo, so the model is reciprocal. Two-sided.
// Sampled as a mixture of the interface lobes' visible normals and the cosine density,
// weighted by their albedos at wo.
#include <algorithm>
#include <array>
#include <cmath>

#include "gonio/twin/detail/bsdf/fresnel.hpp"
#include "gonio/twin/detail/bsdf/microfacet.hpp"
#include "gonio/twin/detail/bsdf/model.hpp"
#include "gonio/twin/detail/bsdf/sampling.hpp"

namespace gonio::twin::bsdf {
namespace {

class Plastic final : public Lobe {
 public:
  Plastic(const Params& p, const WavelengthGrid& grid)
      : Lobe(grid, p.spec()),
        albedo_(p.spectrum("albedo")),
        mean_albedo_(mean(albedo_)),
        sharp_{Distribution::ggx, p.scalar("alpha")},
        halo_{Distribution::ggx, p.scalar("haze_alpha")},
        haze_(p.scalar("haze")),
        ior_(p.scalar("ior")) {
    tabulate_interface_albedo();
    // Per channel, what f_d is without the interface's transmissions.
    for (const double a : albedo_) base_.push_back(a / (1 - a * f_in_) * kInvPi / (ior_ * ior_));
  }

  void eval(const Vec3& wi_in, const Vec3& wo_in, std::span<double> out) const override {
    const auto fr = reflection_frame(wi_in, wo_in);
    if (!fr) {
      for (auto& v : out) v = 0;
      return;
    }
    const double fs = specular(*fr);
    const double d = (1 - R(fr->wi.z)) * (1 - R(fr->wo.z));
    for (std::size_t c = 0; c < out.size(); ++c) out[c] = fs + d * base_[c];
  }

  std::optional<BsdfSample> sample_wi(const Vec3& wo, double u_lobe, Vec2 u) const override {
    if (wo.z == 0) return std::nullopt;
    const double ps = specular_share(wo);
    std::optional<BsdfSample> s;
    if (u_lobe < ps) {
      const double v = u_lobe / ps;  // uniform again: which interface lobe
      s = sample_reflection(v < 1 - haze_ ? sharp_ : halo_, wo, u);
    } else {
      Vec3 wi = sample_cosine_hemisphere(u);
      if (wi.z <= 0) return std::nullopt;
      if (wo.z < 0) wi = flip_z(wi);
      s = BsdfSample{wi, 0};
    }
    if (!s) return std::nullopt;
    s->pdf = pdf(wo, s->wi);
    if (!(s->pdf > 0)) return std::nullopt;
    return s;
  }

  double pdf(const Vec3& wo, const Vec3& wi) const override {
    if (!same_hemisphere(wi, wo)) return 0;
    const double ps = specular_share(wo);
    double spec = (1 - haze_) * reflection_pdf(sharp_, wo, wi);
    if (haze_ > 0) spec += haze_ * reflection_pdf(halo_, wo, wi);
    return ps * spec + (1 - ps) * abs_cos_theta(wi) * kInvPi;
  }

  double albedo_hint(const Vec3& wo) const override {
    return R(abs_cos_theta(wo)) + diffuse_albedo(wo, mean_albedo_);
  }

 private:
  // R(μ) at μ = cos θ = (k/32)²: dense near grazing, where R changes fastest (Fresnel
  // toward 1, then masking at the last degrees of a smooth interface).
  static constexpr int kNodes = 33;
  static constexpr int kStrata = 16; // 16 × 16 stratified visible normals per node

  // f_s on a frame with wi, wo in the upper hemisphere.
  double specular(const ReflectionFrame& f) const noexcept {
    const double F = fresnel_dielectric(dot(f.wi, f.h), ior_);
    const double den = 4.0 * f.wi.z * f.wo.z;
    double d = (1 - haze_) * sharp_.D(f.h) * sharp_.G2(f.wi, f.wo);
    if (haze_ > 0) d += haze_ * halo_.D(f.h) * halo_.G2(f.wi, f.wo);
    return F * d / den;
  }

  // ∫ f_a cos θi dωi for one lobe at wo (wo.z > 0): the mean over visible normals m of
  // F(wo·m) G2 / G1(wo) (Heitz 2014 §5: the estimator of the visible-normal sampler).
  double lobe_albedo(const Microfacet& mf, const Vec3& wo) const noexcept {
    double sum = 0;
    for (int i = 0; i < kStrata; ++i)
      for (int j = 0; j < kStrata; ++j) {
        const Vec2 u{(i + 0.5) / kStrata, (j + 0.5) / kStrata};
        const Vec3 m = mf.sample_visible(wo, u);
        const Vec3 wi = reflect(wo, m);
        if (wi.z <= 0) continue;
        sum += fresnel_dielectric(dot(wo, m), ior_) * mf.G2(wi, wo) / mf.G1(wo);
      }
    return sum / (kStrata * kStrata);
  }

  void tabulate_interface_albedo() {
    for (int k = 0; k < kNodes; ++k) {
      const double x = static_cast<double>(k) / (kNodes - 1);
      const double mu = std::max(1e-4, x * x);
      const Vec3 wo{std::sqrt(1 - mu * mu), 0, mu};
      double r = (1 - haze_) * lobe_albedo(sharp_, wo);
      if (haze_ > 0) r += haze_ * lobe_albedo(halo_, wo);
      r_[static_cast<std::size_t>(k)] = std::clamp(r, 0.0, 1.0);
    }
    // R̄ = ∫ R(μ) 2μ dμ of the interpolated R, by Simpson's rule on each segment (R is
    // linear in √μ there).
    double avg = 0;
    for (int k = 1; k < kNodes; ++k) {
      const double a = static_cast<double>(k - 1) / (kNodes - 1), b = static_cast<double>(k) / (kNodes - 1);
      const auto g = [&](double x) { return R(x * x) * 2 * x * x * 2 * x; };  // dμ = 2x dx
      avg += (b - a) / 6 * (g(a) + 4 * g(0.5 * (a + b)) + g(b));
    }
    f_in_ = 1 - (1 - std::clamp(avg, 0.0, 1.0)) / (ior_ * ior_);
  }

  // R at μ = |cos θ|, linear in √μ between the nodes.
  double R(double mu) const noexcept {
    const double x = std::sqrt(std::clamp(mu, 0.0, 1.0)) * (kNodes - 1);
    const int k = std::min(kNodes - 2, static_cast<int>(x));
    const double t = x - k;
    return (1 - t) * r_[static_cast<std::size_t>(k)] + t * r_[static_cast<std::size_t>(k + 1)];
  }

  // ∫ f_d cos θi dωi at wo for an albedo a.
  double diffuse_albedo(const Vec3& wo, double a) const noexcept {
    const double e = 1 - f_in_;
    return (1 - R(abs_cos_theta(wo))) * a * e / (1 - a * f_in_);
  }

  // The probability of sampling the interface rather than the base, from their albedos.
  double specular_share(const Vec3& wo) const noexcept {
    const double s = R(abs_cos_theta(wo));
    const double d = diffuse_albedo(wo, mean_albedo_);
    if (!(d > 0)) return 1.0;
    return std::clamp(s / (s + d), 0.05, 0.95);
  }

  std::vector<double> albedo_, base_;
  double mean_albedo_;
  Microfacet sharp_, halo_;
  double haze_, ior_;
  std::array<double, kNodes> r_{};
  double f_in_ = 0;
};

BsdfPtr build_plastic(const Params& p, const WavelengthGrid& grid) {
  return std::make_shared<Plastic>(p, grid);
}

}  // namespace

const Registrar kPlasticRegistered{{"plastic",
                             {{"albedo", true, 0, 1, false, 0.5, ""},
                              {"alpha", false, 0.001, 1, false, 0.05, ""},
                              {"ior", false, 1, 4, false, 1.5, ""},
                              {"haze", false, 0, 1, false, 0, ""},
                              {"haze_alpha", false, 0.001, 1, false, 0.3, ""}},
                             &build_plastic}};

}  // namespace gonio::twin::bsdf
