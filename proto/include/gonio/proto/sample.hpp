// Sample catalog entries: what a scan measures and what the twin predicts it against.
//
// A sample has a unique name, free notes, an optional reference BSDF spec for the twin
// (twin/bsdf_spec.md; without one the sample is measured without predictions) and a
// relative tolerance that widens the divergence test (docs/architecture.md §6:
// z = (m − p) / √(σm² + σp² + (tol·p)²)). A catalogue has its own uncertainty: a stated
// relative `model_u` for a hand-entered formula, or what a master reference or a model fitted
// to one carries (`Sample::catalogue`, docs/decision-rule.md "Master references").
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json_fwd.hpp>

namespace gonio {

struct SampleSpec {
  static constexpr std::size_t kMaxNameLength = 128;
  static constexpr std::size_t kMaxNotesLength = 4096;
  static constexpr std::size_t kMaxBsdfLength = 4096;
  static constexpr double kMaxTolerance = 1.0;
  static constexpr double kMaxModelU = 0.5;

  std::string name;                 // [A-Za-z0-9._-], 1..128 characters, unique
  std::string notes;
  std::optional<std::string> bsdf;  // twin spec string; nullopt: no predictions
  double tolerance = 0.02;          // relative, [0, 1]
  double model_u = 0;               // the formula's stated relative u, [0, 0.5]

  // Throws Error naming `<field>.name` etc. The BSDF spec is checked by whoever builds it.
  void validate(std::string_view field = "sample") const;
  friend bool operator==(const SampleSpec&, const SampleSpec&) = default;
};

struct Sample {
  std::int64_t id = 0;
  SampleSpec spec;
  std::string created_at;  // UTC ISO-8601
  // How the catalogue was made when not by hand (JSON text; empty: a formula): "route"
  // ("master" or "model"), "master_scan", a summary of its u, and its data under "points".
  std::string catalogue;
  friend bool operator==(const Sample&, const Sample&) = default;
};

// {"name", "notes", "bsdf" (string or null), "tolerance", "model_u"}; unknown keys rejected.
void to_json(nlohmann::json& j, const SampleSpec& s);
void from_json(const nlohmann::json& j, SampleSpec& s);
// The spec's keys plus "id", "created_at", "route" ("formula", "master", "model") and
// "catalogue" (the stored catalogue without its points; null for a formula) (output only).
void to_json(nlohmann::json& j, const Sample& s);

}  // namespace gonio
