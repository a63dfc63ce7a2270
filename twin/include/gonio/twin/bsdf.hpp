// Bsdf — the interface every scattering model implements.
//
// Conventions (docs/architecture.md §2): directions are unit vectors in the sample frame (normal +z),
// both pointing away from the surface: `wi` toward the light source, `wo` toward the
// receiver. Reflection when wi.z and wo.z share a sign, transmission otherwise.
// f(wi, wo) is in sr⁻¹, per wavelength channel, without the cosine factor; the radiance
// factor of a reflection geometry is β = π f.
//
// Every model is built for one wavelength grid (its spectral parameters are resampled
// onto it at construction) and evaluates all channels at once: geometry never depends on
// wavelength, so one path carries every channel.
//
// Sampling runs from the receiver side: given `wo`, sample_wi() draws the source-side
// direction `wi` with density pdf(wo, wi) (solid angle, scalar, proportional to the
// channel-averaged f·|cos θi| where possible). Ideal specular parts are not in eval /
// sample / pdf: delta_lobes() lists them, so estimators treat them exactly.
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "gonio/proto/spectrum.hpp"
#include "gonio/twin/vec.hpp"

namespace gonio::twin {

struct BsdfSample {
  Vec3 wi;           // sampled source-side direction
  double pdf = 0;    // solid-angle density of wi given wo (> 0)
};

// An ideal specular path: ∫ f(wi', wo) |cos θi'| g(wi') dwi' contributes weight[c]·g(wi).
struct DeltaLobe {
  Vec3 wi;
  std::vector<double> weight;  // per channel
};

class Bsdf {
 public:
  explicit Bsdf(WavelengthGrid grid) : grid_(std::move(grid)) {}
  virtual ~Bsdf() = default;
  Bsdf(const Bsdf&) = delete;
  Bsdf& operator=(const Bsdf&) = delete;

  const WavelengthGrid& wavelengths() const noexcept { return grid_; }
  std::size_t channels() const noexcept { return grid_.size(); }

  // Writes f(wi, wo) for every channel into out (out.size() == channels()).
  virtual void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const = 0;
  // Draws wi given wo from uniforms u_lobe ∈ [0,1) (lobe choice) and u ∈ [0,1)²;
  // nullopt when the draw falls on a direction with zero density.
  virtual std::optional<BsdfSample> sample_wi(const Vec3& wo, double u_lobe, Vec2 u) const = 0;
  virtual double pdf(const Vec3& wo, const Vec3& wi) const = 0;
  // Ideal specular paths for this wo (empty for models without them).
  virtual void delta_lobes(const Vec3& wo, std::vector<DeltaLobe>& out) const {
    (void)wo;
    out.clear();
  }
  virtual bool has_delta() const noexcept { return false; }
  // The canonical spec string this model was built from.
  virtual std::string spec() const = 0;

 private:
  WavelengthGrid grid_;
};

using BsdfPtr = std::shared_ptr<const Bsdf>;

// Builds a model from a spec string (see bsdf_spec.md):
//   lambert:albedo=0.8           mirror:reflectance=0.9
//   conductor:alpha=0.05,eta=0.2,k=3.9     dielectric:alpha=0.1,ior=1.5
//   lambert:albedo=0.5+coat:alpha=0.05,ior=1.5      @path/to/file.bsdf
// A parameter may be a spectrum: albedo=400:0.2,700:0.8 (linear interpolation) or
// albedo=@file.csv. Every parameter is range-checked; unknown keys are rejected.
// Throws gonio::Error naming the lobe and parameter.
BsdfPtr make_bsdf(std::string_view spec, const WavelengthGrid& grid);
// The same from JSON: a spec string, an object {"type": "lambert", "albedo": 0.8}, or an
// array of such objects (a sum of lobes).
BsdfPtr make_bsdf(const nlohmann::json& spec, const WavelengthGrid& grid);
// Spec strings as std::string or literals: both of the overloads above would accept them.
inline BsdfPtr make_bsdf(const std::string& spec, const WavelengthGrid& grid) {
  return make_bsdf(std::string_view(spec), grid);
}
inline BsdfPtr make_bsdf(const char* spec, const WavelengthGrid& grid) {
  return make_bsdf(std::string_view(spec), grid);
}

// Loads a tabulated BSDF file by extension: .bsdf (Zemax/Radiant IS-SA), .ssdd, .binary
// (MERL). Defined in the tabulated family.
BsdfPtr load_bsdf_file(const std::string& path, const WavelengthGrid& grid);

}  // namespace gonio::twin
