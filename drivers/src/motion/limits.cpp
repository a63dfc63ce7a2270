// MotionLimits: the per-axis view of the limits table and the MotionGuard built from it
// (limits.hpp).
#include "gonio/drivers/motion/limits.hpp"

#include "gonio/proto/error.hpp"

namespace gonio::drivers {

SoftLimits MotionLimits::of(Axis axis) const noexcept {
  switch (axis) {
    case Axis::incidence: return {incidence_min, incidence_max};
    case Axis::receive: return {receive_min, receive_max};
    case Axis::rotation: return {rotation_min, rotation_max};
    case Axis::tilt: return {tilt_min, tilt_max};
  }
  return {};
}

MotionGuard MotionLimits::guard(double default_min_separation) const {
  const double sep = min_separation.value_or(default_min_separation);
  if (!(sep >= 0 && sep < 180)) throw Error::out_of_range("min_separation", sep, 0, 180, "°");
  MotionGuard g(sep);
  for (const Axis a : kAllAxes) g.set_limits(a, of(a));
  return g;
}

}  // namespace gonio::drivers
