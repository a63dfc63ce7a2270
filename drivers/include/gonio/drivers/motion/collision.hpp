// MotionGuard — soft limits of every axis and the collision guard of the two arms,
// checked before a single byte of a move reaches a device.
//
// The geometry — the arms' separation, swept paths, the collision zone — is ArmClearance's
// (proto/arms.hpp), the rule goniod's plan check and the planners use too.
//
// Violations throw Error(limit_violation) whose field is the axis name and whose message
// names the axis, the target and the limit.
#pragma once

#include <array>
#include <optional>

#include "gonio/drivers/motion/motion_controller.hpp"
#include "gonio/proto/arms.hpp"

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

  double min_separation_deg() const noexcept { return clearance_.min_separation_deg(); }
  const ArmClearance& clearance() const noexcept { return clearance_; }
  void set_limits(Axis axis, SoftLimits limits);  // throws Error(out_of_range) if min > max
  const std::optional<SoftLimits>& limits(Axis axis) const noexcept;

  // In-plane angle between source and receiver for arm angles θi, θr, in [0, 180].
  static double arm_separation(double incidence_deg, double receive_deg) noexcept {
    return ArmClearance::separation(incidence_deg, receive_deg);
  }

  // Soft limits of `axis` for `target_deg` (also rejects NaN and infinities).
  void check_limits(Axis axis, double target_deg) const;

  // Moving one arm from `from_deg` to `target_deg` while the other arm rests at
  // `other_arm_deg`. Axes other than incidence/receive only get their soft limits checked.
  void check_move(Axis axis, double from_deg, double target_deg,
                  std::optional<double> other_arm_deg) const;

  // Both arms moving at once, from (i0, r0) to (i1, r1), in any interleaving.
  void check_arms(double i0, double i1, double r0, double r1) const;

 private:
  ArmClearance clearance_;
  std::array<std::optional<SoftLimits>, kAllAxes.size()> limits_{};
};

}  // namespace gonio::drivers
