// What scan.fit and instrument.calibrate share: a stored scan's points as the inverse twin's
// measured data, the fit options taken from the twin service, and a stored fit as JSON.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "gonio/daemon/methods/methods.hpp"
#include "gonio/proto/json_util.hpp"
#include "gonio/twin/fit.hpp"

namespace gonio::daemon::methods {

// The most fits scan.get shows (newest first).
inline constexpr std::size_t kFitsShown = 10;

// The measured points of scan `id` (Error not_found naming "scan"; wrong_state when the scan
// has no points yet).
twin::MeasuredData measured_of_scan(const Store& store, std::int64_t id);

// The fit options for the daemon: the twin service's replicates, seed and threads; the
// optional params "samples" (paths per geometry and evaluation) and "max_iterations".
twin::FitOptions read_fit_options(json_util::ObjectReader& r, const TwinService& twin);

// Runs `f`, renaming the field of an Error it throws from the twin's "bsdf…" to `field…`
// (and putting a bare field under `field`).
template <typename F>
auto with_field(const std::string& field, F&& f) -> decltype(f());

// {id, kind, model, created_by, created_at, result}
nlohmann::json fit_json(const StoredFit& f);

// ---- implementation

Error renamed(const Error& e, const std::string& field);

template <typename F>
auto with_field(const std::string& field, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const Error& e) {
    throw renamed(e, field);
  }
}

}  // namespace gonio::daemon::methods
