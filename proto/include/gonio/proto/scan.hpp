// Scan plans and scan records: what a technician submits and what the scheduler tracks.
//
// A ScanPlan is the whole measurement request: a sample, the geometries in measuring order
// (explicit geometries, the named ASTM set and/or grids in the docs/architecture.md §2 syntax, expanded
// once at submission), the wavelengths, how often each geometry is repeated, how often the
// reference white is read, and its place in the queue (priority, optional not-before time).
// Point k of a plan measures geometry k / repeats (repeats of one geometry are consecutive,
// so the arms move once per geometry).
//
// JSON (scan.submit params, see proto/openrpc.json):
//   {"sample": 3 | "glossy-demo", "name": "...",
//    "geometries": ["45as15", "45/-30", "astm", {"theta_i": 45, "theta_r": 0}],
//    "grids": ["in=45;out=-80:80:2"],              // either or both of these two
//    "wavelengths": "400:700:10" | [450, 550],      // default 400:700:10
//    "repeats": 1, "reference": {"mode": "every_point" | "interval" | "start", "interval": 10},
//    "priority": 0, "not_before": "2025-01-01T12:00:00Z",
//    "adaptive": {"mode": "parameters", "model": "conductor:alpha=?", "target_rel_u": 0.02,
//                 "max_points": 40} | {"mode": "curve", "tolerance": 0.01, "max_points": 60}}
// An adaptive plan's geometries are candidates: goniod measures the ones the twin chooses,
// in the order it chooses them, each at most three times in parameters mode and once in
// curve mode (twin/design.md).
// Validation here covers the syntax and the fixed limits; limits that depend on the
// instrument (soft limits, arm collision zone, photometer range) are checked by the daemon.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "gonio/proto/enum_text.hpp"
#include "gonio/proto/geometry.hpp"
#include "gonio/proto/spectrum.hpp"

namespace gonio {

// UTC timestamps at the API: "2025-01-02T03:04:05.678Z" (ISO 8601, RFC 3339 profile).
namespace utc {
using Clock = std::chrono::system_clock;
std::string format(Clock::time_point t);
std::string now();
// Accepts "YYYY-MM-DDTHH:MM:SS[.fraction](Z|+00:00)"; throws Error(invalid_argument)
// naming `field` for anything else (local times are refused: an instrument queue must not
// depend on the server's time zone).
Clock::time_point parse(std::string_view text, std::string_view field = "time");
}  // namespace utc

enum class ReferenceMode {
  every_point,  // read the reference white with every point
  interval,     // every `interval` points (and at the start)
  start,        // once at the start of the scan (and on resume)
};
inline constexpr EnumNames<ReferenceMode, 3> kReferenceModeNames{{
    {ReferenceMode::every_point, "every_point"},
    {ReferenceMode::interval, "interval"},
    {ReferenceMode::start, "start"},
}};
constexpr const auto& enum_names(ReferenceMode) { return kReferenceModeNames; }  // proto/enum_text.hpp

enum class AdaptiveMode {
  parameters,  // fit a model; measure where its parameters' uncertainty falls most
  curve,       // no model; measure where the interpolated curve is least certain
};
inline constexpr EnumNames<AdaptiveMode, 2> kAdaptiveModeNames{{
    {AdaptiveMode::parameters, "parameters"},
    {AdaptiveMode::curve, "curve"},
}};
constexpr const auto& enum_names(AdaptiveMode) { return kAdaptiveModeNames; }  // proto/enum_text.hpp

// The stopping rule of an adaptive scan. The model's syntax (a BSDF spec with '?' marks) is
// checked by the daemon, which knows the models.
struct AdaptivePlan {
  AdaptiveMode mode = AdaptiveMode::parameters;
  std::string model;          // parameters mode
  double target_rel_u = 0.05; // parameters mode: stop when every u/|value| is at most this
  double tolerance = 0.01;    // curve mode: stop when the estimated interpolation error is
                              // at most this, relative to the curve
  int max_points = 50;        // never more; at most 3 × (parameters) or 1 × (curve) the candidates

  friend bool operator==(const AdaptivePlan&, const AdaptivePlan&) = default;
};

struct ScanPlan {
  static constexpr std::size_t kMaxPoints = 100000;
  static constexpr int kMaxRepeats = 100;
  static constexpr int kMinPriority = -100, kMaxPriority = 100;
  static constexpr int kMaxReferenceInterval = 100000;

  std::int64_t sample_id = 0;  // resolved id; 0 while only sample_name is known
  std::string sample_name;     // as submitted when given by name
  std::string name;            // free label, may be empty
  std::vector<Geometry> geometries;
  WavelengthGrid wavelengths = WavelengthGrid::visible();
  int repeats = 1;
  ReferenceMode reference = ReferenceMode::every_point;
  int reference_interval = 10;
  int priority = 0;
  std::optional<std::string> not_before;  // UTC ISO-8601
  std::optional<AdaptivePlan> adaptive;   // the geometries are candidates

  // An adaptive plan's upper bound: it may complete sooner.
  std::size_t point_count() const noexcept {
    if (adaptive) return static_cast<std::size_t>(adaptive->max_points);
    return geometries.size() * static_cast<std::size_t>(repeats);
  }
  // Not for adaptive plans, whose points measure the geometries their loop chose.
  std::size_t geometry_index(std::size_t point) const noexcept {
    return point / static_cast<std::size_t>(repeats);
  }
  // Whether point `k` (counting from the first point measured since the last start or
  // resume, `since_start`) reads the reference.
  bool reads_reference(std::size_t since_start) const noexcept;

  // Fixed limits; throws Error naming the field ("geometries[3].theta_r", "repeats").
  void validate(std::string_view field = "") const;
  friend bool operator==(const ScanPlan&, const ScanPlan&) = default;
};

void to_json(nlohmann::json& j, const AdaptivePlan& a);
void to_json(nlohmann::json& j, const ScanPlan& p);
void from_json(const nlohmann::json& j, ScanPlan& p);

enum class ScanState { queued, running, paused, interrupted, completed, failed, cancelled };
inline constexpr EnumNames<ScanState, 7> kScanStateNames{{
    {ScanState::queued, "queued"},
    {ScanState::running, "running"},
    {ScanState::paused, "paused"},
    {ScanState::interrupted, "interrupted"},
    {ScanState::completed, "completed"},
    {ScanState::failed, "failed"},
    {ScanState::cancelled, "cancelled"},
}};
constexpr const auto& enum_names(ScanState) { return kScanStateNames; }  // proto/enum_text.hpp
inline bool is_final(ScanState s) noexcept {
  return s == ScanState::completed || s == ScanState::failed || s == ScanState::cancelled;
}

// A scan as the daemon tracks it (output of scan.get / scan.list).
struct Scan {
  std::int64_t id = 0;
  ScanPlan plan;
  ScanState state = ScanState::queued;
  std::string reason;          // why it is paused / interrupted / failed / cancelled
  bool predicted = true;       // false when the sample has no reference BSDF
  std::string submitted_by;
  std::string submitted_at;
  std::optional<std::string> started_at, finished_at;
  std::size_t points_total = 0;
  std::size_t points_done = 0;
  std::size_t points_diverged = 0;
  std::int64_t queue_position = 0;  // order among waiting scans (lower runs first)

  friend bool operator==(const Scan&, const Scan&) = default;
};

// Output only. `with_geometries` false leaves out the expanded geometry list (for lists).
nlohmann::json to_json(const Scan& s, bool with_geometries);
void to_json(nlohmann::json& j, const Scan& s);

}  // namespace gonio
