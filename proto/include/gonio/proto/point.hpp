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

// One line of a predicted point's uncertainty budget (GUM): an input quantity of the
// instrument, its standard uncertainty u (one per channel, or one for all), the sensitivity
// of β to it and the contribution u·|c| (with its second-order term) per channel.
struct BudgetEntry {
  std::string component;      // "receive_arm_deg", "reference_white_rel", ...
  std::string distribution;   // "rectangular", "triangular", "normal"
  std::string unit;           // of the input: "deg", "1"
  bool random = false;        // independent from point to point
  std::vector<double> u, sensitivity, contribution;
  // ∂²β/∂x² per channel where β is curved in the input (the arms at a glossy peak); empty
  // where β is linear in it. The verdict's fit uses it for offsets beyond a step.
  std::vector<double> curvature;
  // ∂²β/∂x∂y with the input named `cross_with` (the receive arm's entry: the arms'
  // interaction); empty when none. JSON: "cross": {"with": ..., "values": [...]}.
  std::string cross_with;
  std::vector<double> cross;
  friend bool operator==(const BudgetEntry&, const BudgetEntry&) = default;
};

// ∂β/∂θ per channel for one parameter of the sample's catalogued BSDF (the scan's verdict
// fits them; docs/architecture.md §6).
struct SampleSensitivity {
  std::string parameter;      // "conductor.alpha", "lambert.albedo@600"
  double value = 0;           // catalogued
  std::vector<double> sensitivity;
  friend bool operator==(const SampleSensitivity&, const SampleSensitivity&) = default;
};

// The colour of measured against predicted, judged by the same decision rule as the
// spectrum: CIEDE2000 where CIELAB is defined (β ≤ 1), else the chromaticity distance
// Δu′v′ and the relative luminance apart.
struct ColorCheck {
  std::string kind;           // "ciede2000" or "chromaticity"
  double difference = 0;      // ΔE00, or Δu′v′
  double u = 0;               // its standard uncertainty
  double limit = 0;           // the acceptance limit
  std::optional<double> luminance_ratio, luminance_u;  // chromaticity: Y_m / Y_p and its u
  std::string decision;
  friend bool operator==(const ColorCheck&, const ColorCheck&) = default;
};

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
  bool diverged = false;            // decision == "out_of_tolerance"
  // The decision rule (docs/decision-rule.md): "agrees", "out_of_tolerance" or "undecided";
  // empty without a prediction.
  std::string decision;
  std::vector<double> u_model;      // the twin's u from the instrument's tolerances
  std::vector<BudgetEntry> budget;
  std::vector<SampleSensitivity> sample_sensitivity;
  std::optional<ColorCheck> color;  // in the API and the store as "colour" (a wire name kept)
  std::vector<std::string> flags;   // "no_prediction", "saturated", "reference_read", ...
  // The photometer's integration time the point's readings used (auto-ranging); nullopt:
  // unknown (a photometer that does not report it, or a point stored before it was kept).
  std::optional<double> integration_ms;

  friend bool operator==(const PointRecord&, const PointRecord&) = default;
};

void to_json(nlohmann::json& j, const BudgetEntry& b);
void from_json(const nlohmann::json& j, BudgetEntry& b);
void to_json(nlohmann::json& j, const SampleSensitivity& s);
void from_json(const nlohmann::json& j, SampleSensitivity& s);
void to_json(nlohmann::json& j, const ColorCheck& c);
void from_json(const nlohmann::json& j, ColorCheck& c);
void to_json(nlohmann::json& j, const PointRecord& p);
// Strict: unknown keys rejected, spectra validated (used by the store and by clients).
void from_json(const nlohmann::json& j, PointRecord& p);

}  // namespace gonio
