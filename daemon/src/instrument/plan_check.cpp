// Instrument-specific checks of a scan plan (see plan_check.hpp).
#include "gonio/daemon/instrument/plan_check.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio::daemon {

using drivers::Axis;
using drivers::MotionGuard;

namespace {

Error reject(std::size_t k, const Geometry& g, const std::string& why) {
  const auto field = fmt::format("geometries[{}]", k);
  return Error(Errc::plan_rejected, fmt::format("{} ({}): {}", field, g.to_string(), why), field);
}

}  // namespace

bool arms_can_move(const drivers::MotionGuard& guard, const Geometry& a, const Geometry& b) {
  return guard.clearance().can_move(a, b);
}

void check_plan(const ScanPlan& plan, const MotionGuard& guard, const DeviceFacts& devices) {
  const bool know_axes = !devices.axes.empty();
  const bool has_rotation = std::ranges::find(devices.axes, Axis::rotation) != devices.axes.end();
  const double sep = guard.min_separation_deg();
  const auto& arms = guard.clearance();
  // Arms resting inside the zone (homed there) take the side of the first geometry.
  const bool know_arms = devices.arms && arms.side(*devices.arms);
  const std::optional<long> side =
      know_arms ? arms.side(*devices.arms)
                : plan.geometries.empty() ? std::nullopt : arms.side(plan.geometries.front());
  for (std::size_t k = 0; k < plan.geometries.size(); ++k) {
    const auto& g = plan.geometries[k];
    if (g.phi_i != g.phi_r)
      throw reject(k, g, "out-of-plane geometries with φi ≠ φr need a tilt axis, which this "
                         "instrument does not drive");
    if (g.phi_i != 0 && know_axes && !has_rotation)
      throw reject(k, g, "an azimuth needs the sample rotation axis, which this instrument "
                         "does not have");
    try {
      guard.check_limits(Axis::incidence, g.theta_i);
      guard.check_limits(Axis::receive, g.theta_r);
    } catch (const Error& e) {
      throw reject(k, g, e.what());
    }
    if (const auto why = arms.why_not_clear(g); !why.empty()) throw reject(k, g, why);
    // The arms never leave the side of the collision zone they stand on: the first geometry
    // (an adaptive plan's every candidate, measured in any order) must be on theirs, or —
    // before the arms' position is known — on the first geometry's.
    if ((k == 0 || plan.adaptive) && arms.side(g) != side) {
      const auto from = know_arms ? fmt::format("the arms, which stand at {}", devices.arms->to_string())
                                     : fmt::format("geometries[0] ({})", plan.geometries[0].to_string());
      throw reject(k, g, fmt::format("on the other side of the collision zone from {}: the arms "
                                     "cannot pass through each other (minimum separation {:g}°)",
                                     from, sep));
    }
    if (k > 0 && !plan.adaptive) {
      const auto& prev = plan.geometries[k - 1];
      if (!arms.can_move(prev, g))
        throw reject(k, g, fmt::format("the arms cannot move here from {} without entering the "
                                       "collision zone (minimum separation {:g}°)",
                                       prev.to_string(), sep));
    }
  }
  const auto& grid = devices.photometer_grid;
  if (grid && !grid->empty() && !plan.wavelengths.empty()) {
    const double lo = grid->values().front(), hi = grid->values().back();
    const double a = plan.wavelengths.values().front(), b = plan.wavelengths.values().back();
    if (a < lo - 1e-9 || b > hi + 1e-9)
      throw Error(Errc::plan_rejected,
                  fmt::format("wavelengths: {:g}–{:g} nm is outside the photometer's range "
                              "{:g}–{:g} nm",
                              a, b, lo, hi),
                  "wavelengths");
  }
}

}  // namespace gonio::daemon
