// GuardedMotion — the one place where motion safety is enforced: a MotionController that
// wraps any other and checks every move against its MotionGuard before forwarding it.
//
// A move of `axis` to a target is refused with Error(limit_violation), and never reaches
// the wrapped controller, when the target is outside the axis's soft limits (or not a
// finite angle), or — for the incidence and receive arms, when the guard has a minimum
// separation and the wrapped controller drives both arms — when the path from the arm's
// current position to the target sweeps the arms closer than the minimum separation. The
// current positions are read back from the wrapped controller before every arm move, so
// the check holds whoever else moved the arms. Homing is checked the same way when the
// wrapped controller knows where homing ends (home_position(); soft limits are not applied
// to it, so an axis beyond them can always be brought home). Everything else (axes,
// capabilities, position, status, reset_alarm, stop) passes through unchanged; the time
// spent reading positions counts against the move's timeout.
#pragma once

#include <memory>

#include "gonio/drivers/motion/collision.hpp"
#include "gonio/drivers/motion/motion_controller.hpp"

namespace gonio::drivers {

class GuardedMotion final : public MotionController {
 public:
  // Throws Error(invalid_argument) for a null controller.
  GuardedMotion(std::unique_ptr<MotionController> inner, MotionGuard guard);

  const MotionGuard& guard() const noexcept { return guard_; }
  MotionController& inner() noexcept { return *inner_; }

  MotionCapabilities capabilities() const override;
  std::vector<Axis> axes() const override;
  void move(Axis axis, double target_deg, milliseconds timeout) override;
  double position(Axis axis, milliseconds timeout) override;
  AxisStatus status(Axis axis, milliseconds timeout) override;
  void home(Axis axis, milliseconds timeout) override;
  std::optional<double> home_position(Axis axis) const override;
  void reset_alarm(Axis axis, milliseconds timeout) override;
  void stop(milliseconds timeout) override;

 private:
  // The arm collision check of `axis` going to `target_deg`; returns the time left.
  milliseconds check_path(Axis axis, double target_deg, milliseconds timeout, const char* what);

  std::unique_ptr<MotionController> inner_;
  MotionGuard guard_;
};

}  // namespace gonio::drivers
