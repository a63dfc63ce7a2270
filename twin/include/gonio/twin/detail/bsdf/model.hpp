// The pieces every analytic model shares: the table of its parameters (key, range,
// default — the single source of truth for validation and for bsdf_spec.md), the
// resolved parameter values handed to its constructor, and the Lobe base class.
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gonio/twin/bsdf.hpp"

namespace gonio::twin::bsdf {

struct ParamInfo {
  std::string_view key;
  bool spectral = false;  // may vary with wavelength (else a single number)
  double lo = 0, hi = 0;
  bool lo_open = false;   // lo itself excluded: (lo, hi]
  double fallback = 0;    // default
  std::string_view unit;  // appended to the value in messages, e.g. " deg"
};

class Params;

struct ModelInfo {
  std::string_view name;
  std::vector<ParamInfo> params;
  BsdfPtr (*build)(const Params&, const WavelengthGrid&);
};

// Values of one lobe's parameters after validation and resampling, in the order of its
// ModelInfo, with the canonical spec of the lobe.
class Params {
 public:
  struct Entry {
    std::string key;
    std::vector<double> values;  // one per channel; a scalar is repeated on every channel
  };
  Params(std::vector<Entry> entries, std::string spec)
      : entries_(std::move(entries)), spec_(std::move(spec)) {}

  const std::vector<double>& spectrum(std::string_view key) const;
  double scalar(std::string_view key) const { return spectrum(key).front(); }
  const std::string& spec() const noexcept { return spec_; }

 private:
  std::vector<Entry> entries_;
  std::string spec_;
};

// Base of the analytic models: keeps the canonical spec and offers an estimate of the
// directional albedo, used by sums to choose which lobe to sample.
class Lobe : public Bsdf {
 public:
  Lobe(WavelengthGrid grid, std::string spec) : Bsdf(std::move(grid)), spec_(std::move(spec)) {}
  std::string spec() const override { return spec_; }
  // Channel-averaged estimate of ∫ f |cos θi| dωi for this wo (its sampled part, not the
  // delta lobes). Cheap and deterministic; > 0 wherever eval can be non-zero.
  virtual double albedo_hint(const Vec3& wo) const = 0;

 private:
  std::string spec_;
};

// The albedo hint of any Bsdf: Lobe's own, otherwise a deterministic 8×8 stratified
// estimate through the model's own sampler (for tabulated models inside sums).
double albedo_hint(const Bsdf& b, const Vec3& wo);

double mean(std::span<const double> v) noexcept;

// The models, by name. Each model's file registers it with a namespace-scope
//   const Registrar kNameRegistered{{"name", {params...}, &build}};
// (a name of its own: the unity build compiles several model files as one) run at start-up; twin/CMakeLists.txt links this family whole, so no model is left out.
std::span<const ModelInfo* const> models();
struct Registrar {
  explicit Registrar(ModelInfo info);
};
const ModelInfo* find_model(std::string_view name);

// A sum of lobes (at least two, all on `grid`); its spec joins theirs with '+'.
BsdfPtr make_sum(std::vector<BsdfPtr> lobes, const WavelengthGrid& grid);

}  // namespace gonio::twin::bsdf
