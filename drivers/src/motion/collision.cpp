// MotionGuard: soft limits and the arm collision guard (geometry in motion/collision.hpp).
#include "gonio/drivers/motion/collision.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio::drivers {
namespace {

std::size_t index(Axis a) { return static_cast<std::size_t>(a); }

// Does the closed interval [lo, hi] of summed arm angles come closer than `min` to a
// multiple of 360° (where the arms coincide)? Returns the offending sum if so.
std::optional<double> enters_zone(double lo, double hi, double min) {
  if (min <= 0) return std::nullopt;
  // The smallest multiple of 360° above lo − min; the band around it meets [lo, hi] iff
  // it also lies below hi + min.
  const double centre = (std::floor((lo - min) / 360.0) + 1.0) * 360.0;
  if (centre < hi + min) return std::clamp(centre, lo, hi);
  return std::nullopt;
}

}  // namespace

MotionGuard::MotionGuard(double min_separation_deg) : min_separation_(min_separation_deg) {
  if (!(min_separation_deg >= 0 && min_separation_deg < 180))
    throw Error::out_of_range("min_separation_deg", min_separation_deg, 0, 180, "°");
}

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

double MotionGuard::arm_separation(double incidence_deg, double receive_deg) noexcept {
  const double s = std::fmod(std::abs(incidence_deg + receive_deg), 360.0);
  return s > 180.0 ? 360.0 - s : s;
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
  if (min_separation_ <= 0 || !other_arm_deg) return;
  if (axis == Axis::incidence)
    check_arms(from_deg, target_deg, *other_arm_deg, *other_arm_deg);
  else if (axis == Axis::receive)
    check_arms(*other_arm_deg, *other_arm_deg, from_deg, target_deg);
}

void MotionGuard::check_arms(double i0, double i1, double r0, double r1) const {
  if (min_separation_ <= 0) return;
  const double lo = std::min(i0, i1) + std::min(r0, r1);
  const double hi = std::max(i0, i1) + std::max(r0, r1);
  const auto bad = enters_zone(lo, hi, min_separation_);
  if (!bad) return;
  // Name the arm that moves (the receive arm when both do).
  const bool receive_moves = r0 != r1;
  const Axis axis = receive_moves ? Axis::receive : Axis::incidence;
  const double target = receive_moves ? r1 : i1;
  const double sep_at_target = arm_separation(i1, r1);
  const std::string field(to_text(axis));
  const bool target_bad = sep_at_target < min_separation_;
  throw Error(Errc::limit_violation,
              target_bad
                  ? fmt::format("{}: target {:g}° brings the arms {:g}° apart (incidence {:g}°, "
                                "receive {:g}°), closer than the minimum separation {:g}°",
                                field, target, sep_at_target, i1, r1, min_separation_)
                  : fmt::format("{}: moving to {:g}° sweeps the arms through each other "
                                "(incidence {:g}°→{:g}°, receive {:g}°→{:g}°); minimum "
                                "separation {:g}°",
                                field, target, i0, i1, r0, r1, min_separation_),
              field);
}

}  // namespace gonio::drivers
