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

// Whether the arms can go from `a` to `b` moving one arm, then the other.
bool reachable(const MotionGuard& guard, const Geometry& a, const Geometry& b,
               bool incidence_first) {
  try {
    if (incidence_first) {
      guard.check_move(Axis::incidence, a.theta_i, b.theta_i, a.theta_r);
      guard.check_move(Axis::receive, a.theta_r, b.theta_r, b.theta_i);
    } else {
      guard.check_move(Axis::receive, a.theta_r, b.theta_r, a.theta_i);
      guard.check_move(Axis::incidence, a.theta_i, b.theta_i, b.theta_r);
    }
    return true;
  } catch (const Error&) {
    return false;
  }
}

}  // namespace

bool arms_can_move(const drivers::MotionGuard& guard, const Geometry& a, const Geometry& b) {
  return reachable(guard, a, b, true) || reachable(guard, a, b, false);
}

void check_plan(const ScanPlan& plan, const MotionGuard& guard, const DeviceFacts& devices) {
  const bool know_axes = !devices.axes.empty();
  const bool has_rotation = std::ranges::find(devices.axes, Axis::rotation) != devices.axes.end();
  const double sep = guard.min_separation_deg();
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
    const double s = MotionGuard::arm_separation(g.theta_i, g.theta_r);
    if (s < sep)
      throw reject(k, g, fmt::format("the arms would be {:g}° apart, inside the collision zone "
                                     "(minimum separation {:g}°)",
                                     s, sep));
    if (k > 0 && !plan.adaptive) {
      const auto& prev = plan.geometries[k - 1];
      if (!reachable(guard, prev, g, true) && !reachable(guard, prev, g, false))
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
