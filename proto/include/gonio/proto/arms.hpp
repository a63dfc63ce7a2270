// The two arms of the goniometer and the clearance they keep: the one geometry rule behind
// the motion guard (drivers/motion/collision.hpp), goniod's plan check and the planners
// that propose geometries (gonio-twin plan and design, goniod's adaptive loop).
//
// Arm geometry (docs/architecture.md §2): the source direction for incidence θi is
// (−sin θi, 0, cos θi) and the receiver direction for θr is (sin θr, 0, cos θr). Both arms
// turn in the plane of measurement about the same axis, so the angle between them is
// |θi + θr| wrapped into [0°, 180°]; they collide when it drops below the minimum separation
// (the profile's arms.min_separation_deg, goniod's [instrument.limits] min_separation).
// Retro-reflection (θr = −θi) is the collision point itself.
//
// Paths matter, not only targets: while the arms move, their pair of angles stays in the
// rectangle spanned by the start and end angles of each, and the summed angle θi + θr over
// that rectangle covers the interval between its corner values; a move keeps the clearance
// when that whole interval does (modulo 360°). The runner moves one arm after the other, in
// whichever order keeps it.
//
// Sides: the summed angle of arms that keep their clearance lies in one arc between two
// coincidences, (360°·k + min, 360°·(k + 1) − min). No move leaves its arc — that would sweep
// the arms through each other — so the arc the arms stand in holds every geometry they can
// ever reach: on the usual instrument, with the arms at 0°/45°, no geometry with θr < −θi.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "gonio/proto/geometry.hpp"

namespace gonio {

class ArmClearance {
 public:
  // 0 keeps no clearance (every geometry and move allowed); must be in [0, 180): throws
  // Error(out_of_range) naming `field`.
  explicit ArmClearance(double min_separation_deg = 0,
                        std::string_view field = "min_separation_deg");

  double min_separation_deg() const noexcept { return min_; }

  // In-plane angle between source and receiver for arm angles θi, θr, in [0°, 180°].
  static double separation(double incidence_deg, double receive_deg) noexcept;
  // The arms at this geometry keep the minimum separation.
  bool clear(const Geometry& g) const noexcept;
  // Why they do not ("the arms would be 5° apart, inside the collision zone (minimum
  // separation 10°)"); empty when they do.
  std::string why_not_clear(const Geometry& g) const;

  // Both arms moving from (i0, r0) to (i1, r1), in any interleaving: the summed angle at
  // which they come closer than the minimum, nullopt if they never do.
  std::optional<double> sweep_collision(double i0, double i1, double r0, double r1) const noexcept;
  // One arm after the other from `from` to `to`: whether the incidence arm moves first
  // (preferred when both orders keep the clearance), nullopt when neither order does.
  std::optional<bool> incidence_first(const Geometry& from, const Geometry& to) const noexcept;
  bool can_move(const Geometry& from, const Geometry& to) const noexcept {
    return incidence_first(from, to).has_value();
  }

  // The arc of the summed angle (above) a clear geometry lies in; nullopt inside the zone.
  // Geometries on different sides are never reachable from one another.
  std::optional<long> side(const Geometry& g) const noexcept;

 private:
  double min_ = 0;
};

}  // namespace gonio
