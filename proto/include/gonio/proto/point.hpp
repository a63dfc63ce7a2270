// PointRecord — one measured point of a scan, stored with the twin's prediction beside it.
//
// Measured β(λ) is formed by the scan runner from sample, dark and reference readings
// (β = β_ref (S − D) / (R − D_R), standard uncertainty k = 1 by first-order propagation);
// the prediction is the twin's β(λ) with its standard error at the planned geometry. The
// divergence figures follow docs/architecture.md §6: z per channel from both uncertainties and the
// sample's tolerance, and CIEDE2000 between the two spectra (null when the grid has no
// visible overlap or there is no prediction).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "gonio/proto/geometry.hpp"
#include "gonio/proto/spectrum.hpp"

namespace gonio {

struct PointRecord {
  std::int64_t scan_id = 0;
  std::int64_t index = 0;           // 0-based point index within the plan
  std::int64_t geometry_index = 0;  // index into ScanPlan::geometries
  int repeat = 0;                   // 0-based repeat of that geometry
  Geometry planned;                 // nominal geometry
  Geometry actual;                  // arm positions read back
  std::string started_at, finished_at;  // UTC ISO-8601
  Spectrum measured;                // β with standard uncertainty (plan wavelengths)
  std::optional<Spectrum> predicted;  // β with the twin's standard error; nullopt: none
  std::string twin_version;         // empty without prediction
  std::optional<double> z_max;      // max |z| over channels
  std::optional<double> delta_e00;  // CIEDE2000 measured vs predicted
  bool diverged = false;
  std::vector<std::string> flags;   // "no_prediction", "saturated", "reference_read", ...

  friend bool operator==(const PointRecord&, const PointRecord&) = default;
};

void to_json(nlohmann::json& j, const PointRecord& p);
// Strict: unknown keys rejected, spectra validated (used by the store and by clients).
void from_json(const nlohmann::json& j, PointRecord& p);

}  // namespace gonio
