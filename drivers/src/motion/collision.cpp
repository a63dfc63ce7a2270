// MotionGuard: soft limits and the arm collision guard (the geometry is ArmClearance's, proto/arms.hpp).
#include "gonio/drivers/motion/collision.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio::drivers {
namespace {

std::size_t index(Axis a) { return static_cast<std::size_t>(a); }

}  // namespace

MotionGuard::MotionGuard(double min_separation_deg) : clearance_(min_separation_deg) {}

void MotionGuard::set_limits(Axis axis, SoftLimits limits) {
  const std::string field = std::string(to_text(axis));
  if (!std::isfinite(limits.min_deg) || !std::isfinite(limits.max_deg) ||
      limits.min_deg > limits.max_deg)
    throw Error(Errc::out_of_range,
                fmt::format("{}: soft limits [{:g}°, {:g}°] are not an interval", field,
                            limits.min_deg, limits.max_deg),
                field);
  limits_[index(axis)] = limits;
}

const std::optional<SoftLimits>& MotionGuard::limits(Axis axis) const noexcept {
  return limits_[index(axis)];
}

void MotionGuard::check_limits(Axis axis, double target_deg) const {
  const std::string field(to_text(axis));
  if (!std::isfinite(target_deg))
    throw Error(Errc::limit_violation, fmt::format("{}: target {} is not a finite angle", field,
                                                   target_deg),
                field);
  const auto& lim = limits_[index(axis)];
  if (lim && (target_deg < lim->min_deg || target_deg > lim->max_deg))
    throw Error(Errc::limit_violation,
                fmt::format("{}: target {:g}° is outside the soft limits [{:g}°, {:g}°]", field,
                            target_deg, lim->min_deg, lim->max_deg),
                field);
}

void MotionGuard::check_move(Axis axis, double from_deg, double target_deg,
                             std::optional<double> other_arm_deg) const {
  check_limits(axis, target_deg);
  if (min_separation_deg() <= 0 || !other_arm_deg) return;
  if (axis == Axis::incidence)
    check_arms(from_deg, target_deg, *other_arm_deg, *other_arm_deg);
  else if (axis == Axis::receive)
    check_arms(*other_arm_deg, *other_arm_deg, from_deg, target_deg);
}

void MotionGuard::check_arms(double i0, double i1, double r0, double r1) const {
  if (!clearance_.sweep_collision(i0, i1, r0, r1)) return;
  const double min_separation = min_separation_deg();
  // Name the arm that moves (the receive arm when both do).
  const bool receive_moves = r0 != r1;
  const Axis axis = receive_moves ? Axis::receive : Axis::incidence;
  const double target = receive_moves ? r1 : i1;
  const double sep_at_target = arm_separation(i1, r1);
  const std::string field(to_text(axis));
  const bool target_bad = sep_at_target < min_separation;
  throw Error(Errc::limit_violation,
              target_bad
                  ? fmt::format("{}: target {:g}° brings the arms {:g}° apart (incidence {:g}°, "
                                "receive {:g}°), closer than the minimum separation {:g}°",
                                field, target, sep_at_target, i1, r1, min_separation)
                  : fmt::format("{}: moving to {:g}° sweeps the arms through each other "
                                "(incidence {:g}°→{:g}°, receive {:g}°→{:g}°); minimum "
                                "separation {:g}°",
                                field, target, i0, i1, r0, r1, min_separation),
              field);
}

}  // namespace gonio::drivers
