// MotionLimits — the one table of motion safety: the soft limits of every axis and the
// arms' minimum separation, as goniod's [instrument.limits] states them. Every guard of an
// instrument (the GuardedMotion around its controller, the daemon's plan validation) is
// built from one such table, so that they cannot disagree. Drivers hold no limits of
// their own.
#pragma once

#include <optional>

#include "gonio/drivers/motion/collision.hpp"
#include "gonio/drivers/motion/motion_controller.hpp"

namespace gonio::drivers {

// The arms' clearance when the table leaves it unset and the motion driver has no default
// of its own (the mock's is its profile's arms.min_separation_deg).
inline constexpr double kDefaultMinSeparationDeg = 10;

struct MotionLimits {
  double incidence_min = 0, incidence_max = 85;    // degrees
  double receive_min = -85, receive_max = 85;
  double rotation_min = -360, rotation_max = 360;
  double tilt_min = -360, tilt_max = 360;
  std::optional<double> min_separation;  // degrees; unset: the driver's default (above)

  SoftLimits of(Axis axis) const noexcept;
  // The guard of this table; `default_min_separation` stands in for an unset
  // min_separation. Throws Error(out_of_range) naming the axis or "min_separation" for a
  // range that is not an interval or a separation outside [0, 180).
  MotionGuard guard(double default_min_separation) const;

  friend bool operator==(const MotionLimits&, const MotionLimits&) = default;
};

}  // namespace gonio::drivers
