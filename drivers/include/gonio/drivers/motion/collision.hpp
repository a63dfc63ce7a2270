// MotionGuard — soft limits of every axis and the collision guard of the two arms,
// checked before a single byte of a move reaches a device.
//
// Arm geometry (docs/architecture.md §2): the source direction for incidence θi is (−sin θi, 0, cos θi)
// and the receiver direction for θr is (sin θr, 0, cos θr). Both arms turn in the plane
// of measurement about the same axis, so the angle between them is the in-plane angle
// between the two directions, |θi + θr| wrapped into [0°, 180°]. The arms collide when that
// angle drops below the profile's min_separation_deg (InstrumentProfile::Arms). Retro-
// reflection (θr = −θi) is the collision point itself.
//
// Paths matter, not only targets: an arm moving from 30° to −60° sweeps every angle in
// between. While the arms move, their pair of angles stays in the rectangle spanned by
// the start and end angles of each, and the separation θi + θr over that rectangle covers
// the interval between its corner values; a move is allowed when that whole interval keeps
// the minimum separation (modulo 360°).
//
// Violations throw Error(limit_violation) whose field is the axis name and whose message
// names the axis, the target and the limit.
#pragma once

#include <array>
#include <optional>

#include "gonio/drivers/motion/motion_controller.hpp"

namespace gonio::drivers {

struct SoftLimits {
  double min_deg = -360;
  double max_deg = 360;
  friend bool operator==(const SoftLimits&, const SoftLimits&) = default;
};

class MotionGuard {
 public:
  // 0 disables the arm check; must be in [0, 180).
  explicit MotionGuard(double min_separation_deg = 0);

  double min_separation_deg() const noexcept { return min_separation_; }
  void set_limits(Axis axis, SoftLimits limits);  // throws Error(out_of_range) if min > max
  const std::optional<SoftLimits>& limits(Axis axis) const noexcept;

  // In-plane angle between source and receiver for arm angles θi, θr, in [0, 180].
  static double arm_separation(double incidence_deg, double receive_deg) noexcept;

  // Soft limits of `axis` for `target_deg` (also rejects NaN and infinities).
  void check_limits(Axis axis, double target_deg) const;

  // Moving one arm from `from_deg` to `target_deg` while the other arm rests at
  // `other_arm_deg`. Axes other than incidence/receive only get their soft limits checked.
  void check_move(Axis axis, double from_deg, double target_deg,
                  std::optional<double> other_arm_deg) const;

  // Both arms moving at once, from (i0, r0) to (i1, r1), in any interleaving.
  void check_arms(double i0, double i1, double r0, double r1) const;

 private:
  double min_separation_;
  std::array<std::optional<SoftLimits>, kAllAxes.size()> limits_{};
};

}  // namespace gonio::drivers
