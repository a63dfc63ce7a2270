// ArmClearance (arms.hpp): the arms' separation, swept paths and sides.
#include "gonio/proto/arms.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio {

ArmClearance::ArmClearance(double min_separation_deg, std::string_view field)
    : min_(min_separation_deg) {
  if (!(min_separation_deg >= 0 && min_separation_deg < 180))
    throw Error::out_of_range(std::string(field), min_separation_deg, 0, 180, "°");
}

double ArmClearance::separation(double incidence_deg, double receive_deg) noexcept {
  const double s = std::fmod(std::abs(incidence_deg + receive_deg), 360.0);
  return s > 180.0 ? 360.0 - s : s;
}

bool ArmClearance::clear(const Geometry& g) const noexcept {
  return min_ <= 0 || separation(g.theta_i, g.theta_r) >= min_;
}

std::string ArmClearance::why_not_clear(const Geometry& g) const {
  if (clear(g)) return {};
  return fmt::format("the arms would be {:g}° apart, inside the collision zone (minimum "
                     "separation {:g}°)",
                     separation(g.theta_i, g.theta_r), min_);
}

std::optional<double> ArmClearance::sweep_collision(double i0, double i1, double r0,
                                                    double r1) const noexcept {
  if (min_ <= 0) return std::nullopt;
  const double lo = std::min(i0, i1) + std::min(r0, r1);
  const double hi = std::max(i0, i1) + std::max(r0, r1);
  // The smallest multiple of 360° above lo − min; the band around it meets [lo, hi] iff it
  // also lies below hi + min.
  const double centre = (std::floor((lo - min_) / 360.0) + 1.0) * 360.0;
  if (centre < hi + min_) return std::clamp(centre, lo, hi);
  return std::nullopt;
}

std::optional<bool> ArmClearance::incidence_first(const Geometry& a,
                                                  const Geometry& b) const noexcept {
  const auto clear_path = [&](bool inc_first) {
    // The first arm moves with the other at its start, then the second with the first at
    // its end.
    if (inc_first)
      return !sweep_collision(a.theta_i, b.theta_i, a.theta_r, a.theta_r) &&
             !sweep_collision(b.theta_i, b.theta_i, a.theta_r, b.theta_r);
    return !sweep_collision(a.theta_i, a.theta_i, a.theta_r, b.theta_r) &&
           !sweep_collision(a.theta_i, b.theta_i, b.theta_r, b.theta_r);
  };
  if (clear_path(true)) return true;
  if (clear_path(false)) return false;
  return std::nullopt;
}

std::optional<long> ArmClearance::side(const Geometry& g) const noexcept {
  if (min_ <= 0) return 0;
  if (!clear(g)) return std::nullopt;
  return static_cast<long>(std::floor((g.theta_i + g.theta_r) / 360.0));
}

}  // namespace gonio
