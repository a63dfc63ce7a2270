// gltf — the glTF 2.0 metallic-roughness material as the specification defines it (glTF 2.0,
// Appendix B "BRDF Implementation"), with the layering of KHR_materials_ior,
// KHR_materials_specular and KHR_materials_clearcoat. It is what a glTF viewer renders, so
// the twin can render a material and its glTF approximation side by side and state their
// difference (twin/material.md).
//
//   specular_brdf(α) = V D                                           (B.3.2, B.3.3)
//     D = α² / (π ((N·H)² (α² − 1) + 1)²)                            Trowbridge-Reitz
//     V = 1 / (|N·L| + √(α² + (1 − α²)(N·L)²)) · 1 / (|N·V| + √(α² + (1 − α²)(N·V)²))
//         (the separable Smith form the specification gives, not the height-correlated G2
//         of `conductor`), α = roughness²
//   metal_brdf      = specular_brdf(α) (base + (1 − base) (1 − |V·H|)⁵)        (B.3.4)
//   dielectric_brdf = (1 − specular max_λ(fr)) base / π + specular fr specular_brdf(α),
//     fr = f0 + (1 − f0)(1 − |V·H|)⁵, f0 = min(((1 − ior)/(1 + ior))² specular_color, 1)
//     (KHR_materials_specular's fresnel_mix; with specular = specular_color = 1 it is the
//     core's mix(diffuse, specular_brdf, fr) and with ior = 1.5 its f0 = 0.04)
//   material        = (1 − metallic) dielectric_brdf + metallic metal_brdf
//   coated          = (1 − clearcoat fc) material + clearcoat fc specular_brdf(α_c),
//     fc = 0.04 + 0.96 (1 − |N·V|)⁵ (KHR_materials_clearcoat's fresnel_coat: ior 1.5, the
//     viewing angle, not V·H), α_c = clearcoat_roughness²
//
// L is the source direction wi, V the receiver wo. The colours of the specification are RGB;
// here every colour is a spectrum and each formula runs per wavelength channel (max_λ is
// the specification's max_value over the channels). The clearcoat term depends on N·V alone,
// so a coated material is not reciprocal, as the specification defines it. Two-sided like
// the other reflection models. Sampled as a mixture of the visible normals of both GGX
// lobes and the cosine density, weighted by their estimated albedos at wo.
#include <algorithm>
#include <cmath>

#include "gonio/twin/detail/bsdf/microfacet.hpp"
#include "gonio/twin/detail/bsdf/model.hpp"
#include "gonio/twin/detail/bsdf/sampling.hpp"

namespace gonio::twin::bsdf {
namespace {

// (1 − x)⁵ of Schlick's approximation.
double schlick_weight(double cos_theta) noexcept {
  const double x = std::clamp(1.0 - std::abs(cos_theta), 0.0, 1.0);
  const double x2 = x * x;
  return x2 * x2 * x;
}

// The specification's specular_brdf = V D for a reflection pair in the upper hemisphere.
double specular_brdf(double alpha, const ReflectionFrame& f) noexcept {
  const double a2 = alpha * alpha;
  const double nh = f.h.z, nl = f.wi.z, nv = f.wo.z;
  const double t = nh * nh * (a2 - 1) + 1;
  const double d = a2 / (kPi * t * t);
  const double vis = 1.0 / ((nl + std::sqrt(a2 + (1 - a2) * nl * nl)) *
                            (nv + std::sqrt(a2 + (1 - a2) * nv * nv)));
  return d * vis;
}

class Gltf final : public Lobe {
 public:
  Gltf(const Params& p, const WavelengthGrid& grid)
      : Lobe(grid, p.spec()),
        base_(p.spectrum("base_color")),
        metallic_(p.scalar("metallic")),
        alpha_(p.scalar("roughness") * p.scalar("roughness")),
        specular_(p.scalar("specular")),
        clearcoat_(p.scalar("clearcoat")),
        alpha_c_(p.scalar("clearcoat_roughness") * p.scalar("clearcoat_roughness")),
        mean_base_(mean(base_)) {
    const double ior = p.scalar("ior");
    const double f0 = (1 - ior) / (1 + ior) * ((1 - ior) / (1 + ior));
    for (const double s : p.spectrum("specular_color")) f0_.push_back(std::min(1.0, f0 * s));
  }

  void eval(const Vec3& wi_in, const Vec3& wo_in, std::span<double> out) const override {
    const auto fr = reflection_frame(wi_in, wo_in);
    if (!fr) {
      for (auto& v : out) v = 0;
      return;
    }
    const double x = schlick_weight(dot(fr->wo, fr->h));
    const double spec = specular_brdf(alpha_, *fr);
    double max_fr = 0;
    for (const double f0 : f0_) max_fr = std::max(max_fr, f0 + (1 - f0) * x);
    const double coat = clearcoat_ * (0.04 + 0.96 * schlick_weight(fr->wo.z));
    const double coat_spec = coat > 0 ? coat * specular_brdf(alpha_c_, *fr) : 0.0;
    for (std::size_t c = 0; c < out.size(); ++c) {
      const double b = base_[c];
      const double f_r = f0_[c] + (1 - f0_[c]) * x;
      const double dielectric = (1 - specular_ * max_fr) * b * kInvPi + specular_ * f_r * spec;
      const double metal = spec * (b + (1 - b) * x);
      out[c] = (1 - coat) * ((1 - metallic_) * dielectric + metallic_ * metal) + coat_spec;
    }
  }

  std::optional<BsdfSample> sample_wi(const Vec3& wo, double u_lobe, Vec2 u) const override {
    if (wo.z == 0) return std::nullopt;
    const auto w = shares(wo);
    std::optional<BsdfSample> s;
    if (u_lobe < w[0]) {
      s = sample_reflection({Distribution::ggx, alpha_}, wo, u);
    } else if (u_lobe < w[0] + w[1]) {
      s = sample_reflection({Distribution::ggx, alpha_c_}, wo, u);
    } else {
      Vec3 wi = sample_cosine_hemisphere(u);
      if (wi.z <= 0) return std::nullopt;
      s = BsdfSample{wo.z < 0 ? flip_z(wi) : wi, 0};
    }
    if (!s) return std::nullopt;
    s->pdf = pdf(wo, s->wi);
    if (!(s->pdf > 0)) return std::nullopt;
    return s;
  }

  double pdf(const Vec3& wo, const Vec3& wi) const override {
    if (!same_hemisphere(wi, wo)) return 0;
    const auto w = shares(wo);
    double p = w[2] * abs_cos_theta(wi) * kInvPi;
    if (w[0] > 0) p += w[0] * reflection_pdf({Distribution::ggx, alpha_}, wo, wi);
    if (w[1] > 0) p += w[1] * reflection_pdf({Distribution::ggx, alpha_c_}, wo, wi);
    return p;
  }

  double albedo_hint(const Vec3& wo) const override {
    const auto a = albedos(abs_cos_theta(wo));
    return a[0] + a[1] + a[2];
  }

 private:
  // Rough albedos at cos θo of the specular lobe, the clearcoat and the diffuse part, with
  // each lobe's Fresnel weight taken at θo (an estimate: it only steers sampling).
  std::array<double, 3> albedos(double mu) const noexcept {
    const double x = schlick_weight(mu);
    double max_fr = 0, mean_fr = 0;
    for (const double f0 : f0_) {
      max_fr = std::max(max_fr, f0 + (1 - f0) * x);
      mean_fr += (f0 + (1 - f0) * x) / static_cast<double>(f0_.size());
    }
    const double coat = clearcoat_ * (0.04 + 0.96 * x);
    const double metal = mean_base_ + (1 - mean_base_) * x;
    const double spec = (1 - metallic_) * specular_ * mean_fr + metallic_ * metal;
    const double diffuse = (1 - metallic_) * (1 - specular_ * max_fr) * mean_base_;
    return {(1 - coat) * spec, coat, (1 - coat) * diffuse};
  }

  // Probabilities of sampling the specular lobe, the clearcoat and the cosine density; a
  // lobe that can reflect keeps at least 5 %, so that no part is starved.
  std::array<double, 3> shares(const Vec3& wo) const noexcept {
    auto a = albedos(abs_cos_theta(wo));
    const bool present[3] = {true, clearcoat_ > 0, metallic_ < 1 && mean_base_ > 0};
    double sum = 0;
    for (int k = 0; k < 3; ++k) {
      a[static_cast<std::size_t>(k)] =
          present[k] ? std::max(a[static_cast<std::size_t>(k)], 0.05) : 0.0;
      sum += a[static_cast<std::size_t>(k)];
    }
    for (auto& v : a) v /= sum;
    return a;
  }

  std::vector<double> base_, f0_;
  double metallic_, alpha_, specular_, clearcoat_, alpha_c_, mean_base_;
};

BsdfPtr build_gltf(const Params& p, const WavelengthGrid& grid) {
  return std::make_shared<Gltf>(p, grid);
}

}  // namespace

// Roughness from 0.03 (α ≈ 0.001, the narrowest lobe the microfacet sampler resolves; the
// specification's 0 is an ideal mirror). Defaults are the specification's, but for the
// clearcoat roughness (0 there).
const Registrar kGltfRegistered{{"gltf",
                                 {{"base_color", true, 0, 1, false, 1, ""},
                                  {"metallic", false, 0, 1, false, 1, ""},
                                  {"roughness", false, 0.03, 1, false, 1, ""},
                                  {"ior", false, 1, 4, false, 1.5, ""},
                                  {"specular", false, 0, 1, false, 1, ""},
                                  {"specular_color", true, 0, 25, false, 1, ""},
                                  {"clearcoat", false, 0, 1, false, 0, ""},
                                  {"clearcoat_roughness", false, 0.03, 1, false, 0.03, ""}},
                                 &build_gltf}};

}  // namespace gonio::twin::bsdf
