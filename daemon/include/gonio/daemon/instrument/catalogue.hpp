// Catalogue — what a sample's catalogue is beyond its BSDF spec: the route it was made by
// and its own uncertainty at every geometry (docs/decision-rule.md, "Master references").
//
//   formula  a hand-entered spec; its u is the stated relative `model_u` (0: none)
//   master   the instrument-corrected β of a completed scan, interpolated along the
//            aspecular angle (twin::Master); its u is the master's own u there and the
//            interpolation's
//   model    a spec fitted to a master; its u is the fit's misfit beyond the noise, per
//            aspecular region
//
// The u joins every point's GUM budget as the entry "catalogue" (catalogue_entry): random,
// relative, sensitivity β, so that the point rule, the colour check and the verdict's weights
// all see it. A catalogue without u adds nothing.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gonio/proto/geometry.hpp"
#include "gonio/proto/sample.hpp"
#include "gonio/proto/spectrum.hpp"
#include "gonio/twin/budget.hpp"
#include "gonio/twin/master.hpp"

namespace gonio::daemon {

// One aspecular region of a model's misfit: |θi − θr| in [lo, hi).
struct MisfitBin {
  double lo = 0, hi = 0;
  std::size_t points = 0;
  double rms_relative = 0;    // RMS of (measured − fitted) / fitted
  double noise_relative = 0;  // RMS of what the master's and the twin's u explain
  double u = 0;               // √max(0, rms² − noise²): the model's own relative u
};

class Catalogue {
 public:
  enum class Route { formula, master, model };

  // A sample's catalogue (its stored JSON, or its model_u for a formula). Throws Error
  // (internal) for stored JSON it cannot read.
  static Catalogue of(const Sample& sample);
  // `scan`: the master scan (none for a master loaded from a file).
  static Catalogue master(std::optional<std::int64_t> scan, twin::Master corrected, nlohmann::json correction);
  static Catalogue model(std::int64_t scan, std::string spec, std::vector<MisfitBin> bins,
                         nlohmann::json fit);

  Route route() const noexcept { return route_; }
  std::optional<std::int64_t> master_scan() const noexcept { return scan_; }
  bool has_u() const noexcept;

  // Empty when the catalogue predicts g; otherwise why not (a master covers its own
  // incidence angles and receiving range only).
  std::string uncovered(const Geometry& g) const;
  // The catalogue's relative u per channel of `grid` at g (linear in λ between the master's
  // wavelengths, constant beyond); empty when it has none.
  std::vector<double> relative_u(const Geometry& g, const WavelengthGrid& grid) const;

  // The stored form (Sample::catalogue): {"route", "master_scan", "summary", ...,
  // "points"}; empty text for a formula.
  std::string stored() const;
  const twin::Master* master_data() const noexcept { return master_ ? &*master_ : nullptr; }

 private:
  Route route_ = Route::formula;
  std::optional<std::int64_t> scan_;
  double model_u_ = 0;
  std::optional<twin::Master> master_;
  std::string spec_;
  std::vector<MisfitBin> bins_;
  nlohmann::json extra_ = nlohmann::json::object();  // correction / fit, as stored
};

// The budget's line for a catalogue u (relative, per channel) at a predicted β: random,
// normal, unit "1", sensitivity β, contribution u·β; u_model and u_random take it in
// quadrature. Nothing when `u` is empty or all zero.
void add_catalogue_entry(twin::Budget& budget, const std::vector<double>& beta,
                         const std::vector<double>& u);

nlohmann::json to_json(const twin::MasterPoint& p);
twin::MasterPoint master_point_from_json(const nlohmann::json& j, const std::string& field);

}  // namespace gonio::daemon
