// Alerts: what the divergence monitor and the instrument raise for people to look at.
//
// An alert has a kind, a severity and a deduplication key: while an alert with the same
// key is unacknowledged, a repeat only bumps its count and last_at (one alert per cause,
// not one per point). A technician acknowledges it; the next occurrence opens a new one.
// An alert stands until goniod resolves it: a sustained divergence alert whose scan ended
// with a verdict that no longer supports it gets resolved_at and a resolution (the final
// verdict's summary). Acknowledged and resolved are independent: one is people, the other
// the evidence.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json_fwd.hpp>

#include "gonio/proto/enum_text.hpp"

namespace gonio {

enum class Severity { info, warning, critical };
inline constexpr EnumNames<Severity, 3> kSeverityNames{{
    {Severity::info, "info"},
    {Severity::warning, "warning"},
    {Severity::critical, "critical"},
}};
constexpr const auto& enum_names(Severity) { return kSeverityNames; }  // proto/enum_text.hpp

// Stable alert kinds.
namespace alert_kind {
inline constexpr std::string_view divergence = "divergence";            // a point diverged
inline constexpr std::string_view sustained = "sustained_divergence";   // the scan's verdict
inline constexpr std::string_view calibration_hint = "calibration_hint"; // an in-spec offset to calibrate
inline constexpr std::string_view reference_drift = "reference_drift";  // instrument health
inline constexpr std::string_view device_fault = "device_fault";        // scan paused by a fault
inline constexpr std::string_view scan_failed = "scan_failed";
inline constexpr std::string_view storage = "storage";  // the store cannot write, or space is low
}  // namespace alert_kind

struct Alert {
  std::int64_t id = 0;
  std::string kind;
  Severity severity = Severity::warning;
  std::string dedup_key;
  std::optional<std::int64_t> scan_id;
  std::optional<std::int64_t> sample_id;
  std::optional<std::int64_t> point_index;  // the latest point concerned
  std::string message;
  std::string first_at, last_at;  // UTC ISO-8601
  std::int64_t count = 1;
  bool acknowledged = false;
  std::string acknowledged_by;
  std::optional<std::string> acknowledged_at;
  std::optional<std::string> resolved_at;  // UTC ISO-8601; null while the alert stands
  std::optional<std::string> resolution;   // why it no longer stands

  friend bool operator==(const Alert&, const Alert&) = default;
};

void to_json(nlohmann::json& j, const Alert& a);
void from_json(const nlohmann::json& j, Alert& a);

}  // namespace gonio
