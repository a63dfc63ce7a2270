// GuardedMotion: every move checked by the one MotionGuard before it reaches the wrapped
// controller (guarded_motion.hpp).
#include "gonio/drivers/motion/guarded_motion.hpp"

#include <chrono>
#include <optional>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio::drivers {
namespace {

using Clock = std::chrono::steady_clock;

std::optional<Axis> other_arm(Axis axis) {
  if (axis == Axis::incidence) return Axis::receive;
  if (axis == Axis::receive) return Axis::incidence;
  return std::nullopt;
}

}  // namespace

GuardedMotion::GuardedMotion(std::unique_ptr<MotionController> inner, MotionGuard guard)
    : inner_(std::move(inner)), guard_(guard) {
  if (!inner_) throw Error::invalid("motion", "no motion controller to guard");
}

MotionCapabilities GuardedMotion::capabilities() const { return inner_->capabilities(); }

std::vector<Axis> GuardedMotion::axes() const { return inner_->axes(); }

milliseconds GuardedMotion::check_path(Axis axis, double target_deg, milliseconds timeout,
                                       const char* what) {
  const auto deadline = Clock::now() + timeout;
  const auto other = other_arm(axis);
  if (other && guard_.min_separation_deg() > 0 && inner_->has_axis(axis) &&
      inner_->has_axis(*other)) {
    const double from = inner_->position(axis, timeout);
    const double other_deg = inner_->position(*other, timeout);
    guard_.check_move(axis, from, target_deg, other_deg);
  }
  const auto left = std::chrono::duration_cast<milliseconds>(deadline - Clock::now());
  if (left.count() <= 0)
    throw Error(Errc::timeout,
                fmt::format("{}: no time left for the {} to {:g}° after reading the arm "
                            "positions ({} ms)",
                            to_text(axis), what, target_deg, timeout.count()),
                std::string(to_text(axis)));
  return left;
}

void GuardedMotion::move(Axis axis, double target_deg, milliseconds timeout) {
  guard_.check_limits(axis, target_deg);
  inner_->move(axis, target_deg, check_path(axis, target_deg, timeout, "move"));
}

double GuardedMotion::position(Axis axis, milliseconds timeout) { return inner_->position(axis, timeout); }

AxisStatus GuardedMotion::status(Axis axis, milliseconds timeout) { return inner_->status(axis, timeout); }

void GuardedMotion::home(Axis axis, milliseconds timeout) {
  if (const auto end = inner_->home_position(axis)) timeout = check_path(axis, *end, timeout, "homing");
  inner_->home(axis, timeout);
}

std::optional<double> GuardedMotion::home_position(Axis axis) const { return inner_->home_position(axis); }

void GuardedMotion::reset_alarm(Axis axis, milliseconds timeout) { inner_->reset_alarm(axis, timeout); }

void GuardedMotion::stop(milliseconds timeout) { inner_->stop(timeout); }

}  // namespace gonio::drivers
