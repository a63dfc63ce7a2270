// Arm moves: the order in which the axes move (or home) so that the arms keep their
// clearance all the way (proto/arms.hpp), and the one type that carries those moves out on
// the runner thread — for a scan's points (docs/architecture.md §6, step 3) and for the
// manual instrument.move and instrument.home.
//
// Homing references an axis; it need not leave the arms at their home switches. Where an
// arm's homing end lies inside the clearance of the other arm (the mock homes both arms to
// 0°, where they coincide), the other arm, once its position is known, is first moved clear
// of the homing path — to one degree beyond the minimum separation, on the side of the
// collision zone the arms stand on — and the arm is homed after it.
#pragma once

#include <chrono>
#include <functional>
#include <map>
#include <optional>
#include <vector>

#include "gonio/drivers/motion/collision.hpp"
#include "gonio/drivers/motion/motion_controller.hpp"

namespace gonio::daemon {

using AxisPositions = std::map<drivers::Axis, double>;

// One motion of one axis: a move to `deg`, or homing (`deg`: where homing leaves the axis,
// when the controller knows it).
struct ArmStep {
  enum class Kind { move, home };
  Kind kind = Kind::move;
  drivers::Axis axis = drivers::Axis::incidence;
  std::optional<double> deg;
  bool operator==(const ArmStep&) const = default;
};

// The moves taking the arms from `at` to (incidence, receive) and the rotation stage to
// `rotation`: one arm after the other, incidence first when both orders keep the clearance;
// an axis already there is not moved. Positions not in `at` are unknown (both arms move,
// incidence first). Throws the guard's Error(limit_violation) when neither order keeps it.
std::vector<ArmStep> arm_moves(const drivers::MotionGuard& guard, const AxisPositions& at,
                               double incidence, double receive, std::optional<double> rotation);

// Homing `axes` in turn from `at`, with the clearing moves described above.
// `home_position`: where homing leaves an axis (nullopt: unknown, homed as it stands).
// Throws Error(limit_violation) when the other arm cannot be moved clear.
std::vector<ArmStep> homing_steps(const drivers::MotionGuard& guard, AxisPositions at,
                                  const std::vector<drivers::Axis>& axes,
                                  const std::function<std::optional<double>(drivers::Axis)>& home_position);

// Carries out arm steps on a motion controller (runner thread).
class ArmMover {
 public:
  struct Timeouts {
    std::chrono::milliseconds move{30000}, home{120000};
  };
  // `beat` before every device call (the watchdog's heartbeat); `moved` after every step
  // with the step and where its axis stands now (a homed axis is read back).
  using Moved = std::function<void(const ArmStep&, double)>;
  ArmMover(const drivers::MotionGuard& guard, Timeouts timeouts, std::function<void()> beat, Moved moved);

  void move(drivers::MotionController& m, const AxisPositions& at, double incidence, double receive,
            std::optional<double> rotation) const;
  void home(drivers::MotionController& m, const AxisPositions& at, const std::vector<drivers::Axis>& axes) const;
  void run(drivers::MotionController& m, const std::vector<ArmStep>& steps) const;

 private:
  const drivers::MotionGuard& guard_;
  Timeouts timeouts_;
  std::function<void()> beat_;
  Moved moved_;
};

}  // namespace gonio::daemon
