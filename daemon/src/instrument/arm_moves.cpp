// Arm moves and the homing order (arm_moves.hpp).
#include "gonio/daemon/instrument/arm_moves.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/proto/geometry.hpp"

namespace gonio::daemon {

using drivers::Axis;

namespace {

// Positions closer than this are the same (a move there is not made).
constexpr double kSameDeg = 1e-9;
// How far beyond the minimum separation an arm moved clear of a homing path stands.
constexpr double kClearMarginDeg = 1;

bool differs(const AxisPositions& at, Axis a, double deg) {
  const auto it = at.find(a);
  return it == at.end() || std::abs(it->second - deg) > kSameDeg;
}

std::optional<double> known(const AxisPositions& at, Axis a) {
  const auto it = at.find(a);
  return it == at.end() ? std::nullopt : std::optional<double>(it->second);
}

ArmStep move_to(Axis a, double deg) { return ArmStep{.kind = ArmStep::Kind::move, .axis = a, .deg = deg}; }

// Where `other` must stand so that the arm `a`, at `from`, homes to `end` keeping the
// clearance: nearest to where it stands, on the arms' side of the collision zone.
double clear_of_homing(const drivers::MotionGuard& guard, Axis a, double from, double end, double other_at) {
  const double min = guard.min_separation_deg();
  const auto g = a == Axis::incidence ? Geometry::in_plane(from, other_at) : Geometry::in_plane(other_at, from);
  const auto side = guard.clearance().side(g);
  if (!side)
    throw Error(Errc::limit_violation,
                fmt::format("{}: the arms stand inside the collision zone; move them apart by hand before homing",
                            to_text(a)),
                std::string(to_text(a)));
  // The summed angle θi + θr over the homing path must stay in the side's arc.
  const double lo = 360.0 * static_cast<double>(*side) + min + kClearMarginDeg - std::min(from, end);
  const double hi = 360.0 * static_cast<double>(*side + 1) - min - kClearMarginDeg - std::max(from, end);
  if (lo > hi)
    throw Error(Errc::limit_violation,
                fmt::format("{}: homing from {:g}° to {:g}° sweeps the whole clearance arc; no position "
                            "of the other arm keeps the minimum separation {:g}°",
                            to_text(a), from, end, min),
                std::string(to_text(a)));
  return std::clamp(other_at, lo, hi);
}

}  // namespace

std::vector<ArmStep> arm_moves(const drivers::MotionGuard& guard, const AxisPositions& at, double incidence,
                               double receive, std::optional<double> rotation) {
  std::vector<ArmStep> steps;
  const auto cur_i = known(at, Axis::incidence), cur_r = known(at, Axis::receive);
  const bool know = cur_i && cur_r;
  bool incidence_first = true;
  if (know) {
    try {
      guard.check_move(Axis::incidence, *cur_i, incidence, *cur_r);
      guard.check_move(Axis::receive, *cur_r, receive, incidence);
    } catch (const Error&) {
      guard.check_move(Axis::receive, *cur_r, receive, *cur_i);
      guard.check_move(Axis::incidence, *cur_i, incidence, receive);
      incidence_first = false;
    }
  }
  const auto add = [&](Axis a, double deg) {
    if (!know || differs(at, a, deg)) steps.push_back(move_to(a, deg));
  };
  if (incidence_first) {
    add(Axis::incidence, incidence);
    add(Axis::receive, receive);
  } else {
    add(Axis::receive, receive);
    add(Axis::incidence, incidence);
  }
  if (rotation && differs(at, Axis::rotation, *rotation)) steps.push_back(move_to(Axis::rotation, *rotation));
  return steps;
}

std::vector<ArmStep> homing_steps(const drivers::MotionGuard& guard, AxisPositions at,
                                  const std::vector<Axis>& axes,
                                  const std::function<std::optional<double>(Axis)>& home_position) {
  std::vector<ArmStep> steps;
  for (const Axis a : axes) {
    const auto end = home_position(a);
    const bool arm = a == Axis::incidence || a == Axis::receive;
    const Axis other = a == Axis::incidence ? Axis::receive : Axis::incidence;
    const auto from = known(at, a), other_at = known(at, other);
    if (arm && end && from && other_at && guard.min_separation_deg() > 0) {
      try {
        guard.check_move(a, *from, *end, *other_at);
      } catch (const Error&) {
        const double clear = clear_of_homing(guard, a, *from, *end, *other_at);
        try {
          guard.check_move(other, *other_at, clear, *from);
        } catch (const Error& e) {
          throw Error(Errc::limit_violation,
                      fmt::format("{}: homing to {:g}° needs the {} arm clear of it at {:g}°, which it "
                                  "cannot reach: {}",
                                  to_text(a), *end, to_text(other), clear, e.what()),
                      std::string(to_text(a)));
        }
        steps.push_back(move_to(other, clear));
        at[other] = clear;
      }
    }
    steps.push_back(ArmStep{.kind = ArmStep::Kind::home, .axis = a, .deg = end});
    if (end) at[a] = *end;
    else at.erase(a);
  }
  return steps;
}

ArmMover::ArmMover(const drivers::MotionGuard& guard, Timeouts timeouts, std::function<void()> beat, Moved moved)
    : guard_(guard), timeouts_(timeouts), beat_(std::move(beat)), moved_(std::move(moved)) {}

void ArmMover::move(drivers::MotionController& m, const AxisPositions& at, double incidence, double receive,
                    std::optional<double> rotation) const {
  run(m, arm_moves(guard_, at, incidence, receive, rotation));
}

void ArmMover::home(drivers::MotionController& m, const AxisPositions& at, const std::vector<Axis>& axes) const {
  run(m, homing_steps(guard_, at, axes, [&](Axis a) { return m.home_position(a); }));
}

void ArmMover::run(drivers::MotionController& m, const std::vector<ArmStep>& steps) const {
  for (const auto& s : steps) {
    beat_();
    if (s.kind == ArmStep::Kind::move) {
      m.move(s.axis, *s.deg, timeouts_.move);
      moved_(s, *s.deg);
    } else {
      m.home(s.axis, timeouts_.home);
      beat_();
      moved_(s, m.position(s.axis, timeouts_.move));
    }
  }
}

}  // namespace gonio::daemon
