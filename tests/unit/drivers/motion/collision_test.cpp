// MotionGuard: soft limits and the arm collision guard (targets and swept paths), with
// errors that name the axis, the target and the limit.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "gonio/drivers/motion/collision.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/test/error_of.hpp"

using gonio::Errc;
using gonio::Error;
using gonio::test::error_of;
using gonio::drivers::Axis;
using gonio::drivers::MotionGuard;
using gonio::drivers::SoftLimits;

namespace {

bool contains(const Error& e, const std::string& s) {
  return std::string(e.what()).find(s) != std::string::npos;
}

}  // namespace

TEST(MotionGuard, ArmSeparationFollowsTheSampleFrame) {
  // Specular at 45°: source at −45°, receiver at +45° from the normal: 90° apart.
  EXPECT_DOUBLE_EQ(MotionGuard::arm_separation(45, 45), 90);
  // Retro-reflection: the arms coincide.
  EXPECT_DOUBLE_EQ(MotionGuard::arm_separation(45, -45), 0);
  EXPECT_DOUBLE_EQ(MotionGuard::arm_separation(30, -20), 10);
  EXPECT_DOUBLE_EQ(MotionGuard::arm_separation(0, 0), 0);
  // Transmission: the receiver beyond 90° wraps around the far side.
  EXPECT_DOUBLE_EQ(MotionGuard::arm_separation(10, 180), 170);
  EXPECT_DOUBLE_EQ(MotionGuard::arm_separation(30, 320), 10);
  // Independent check against the direction vectors of docs/architecture.md §2.
  for (double ti = -80; ti <= 80; ti += 13)
    for (double tr = -170; tr <= 170; tr += 17) {
      const double r = M_PI / 180;
      const double dot = -std::sin(ti * r) * std::sin(tr * r) + std::cos(ti * r) * std::cos(tr * r);
      EXPECT_NEAR(MotionGuard::arm_separation(ti, tr), std::acos(std::clamp(dot, -1.0, 1.0)) / r, 1e-6)
          << ti << " " << tr;
    }
}

TEST(MotionGuard, SoftLimitsNameAxisTargetAndLimit) {
  MotionGuard g;
  g.set_limits(Axis::incidence, {-5, 85});
  EXPECT_NO_THROW(g.check_limits(Axis::incidence, 85));
  EXPECT_NO_THROW(g.check_limits(Axis::incidence, -5));
  const Error e = error_of([&] { g.check_limits(Axis::incidence, 85.5); });
  EXPECT_EQ(e.code(), Errc::limit_violation);
  EXPECT_EQ(e.field(), "incidence");
  EXPECT_TRUE(contains(e, "incidence"));
  EXPECT_TRUE(contains(e, "85.5"));
  EXPECT_TRUE(contains(e, "[-5°, 85°]"));
  EXPECT_EQ(error_of([&] { g.check_limits(Axis::incidence, NAN); }).code(), Errc::limit_violation);
  // Axes without limits only reject non-finite targets.
  EXPECT_NO_THROW(g.check_limits(Axis::tilt, 1000));
  EXPECT_EQ(error_of([&] { g.set_limits(Axis::tilt, {5, -5}); }).code(), Errc::out_of_range);
}

TEST(MotionGuard, RejectsTargetsInsideTheCollisionZone) {
  MotionGuard g(10);
  // Receive arm to −40° with the source at 45°: 5° apart.
  const Error e = error_of([&] { g.check_move(Axis::receive, 30, -40, 45.0); });
  EXPECT_EQ(e.code(), Errc::limit_violation);
  EXPECT_EQ(e.field(), "receive");
  EXPECT_TRUE(contains(e, "-40"));
  EXPECT_TRUE(contains(e, "10°"));
  EXPECT_NO_THROW(g.check_move(Axis::receive, 30, -35, 45.0));  // exactly 10° apart
  EXPECT_EQ(error_of([&] { g.check_move(Axis::incidence, 0, 25, -20.0); }).field(), "incidence");
  // Unknown other arm, other axes, or a disabled guard: limits only.
  EXPECT_NO_THROW(g.check_move(Axis::receive, 30, -45, std::nullopt));
  EXPECT_NO_THROW(g.check_move(Axis::rotation, 0, 1, 0.0));
  EXPECT_NO_THROW(MotionGuard(0).check_move(Axis::receive, 30, -45, 45.0));
}

TEST(MotionGuard, RejectsPathsThatSweepThroughTheOtherArm) {
  MotionGuard g(10);
  // Source at 45°; receiver from +30° to −80°: its end is 35° away, but it passes −45°.
  const Error e = error_of([&] { g.check_move(Axis::receive, 30, -80, 45.0); });
  EXPECT_EQ(e.code(), Errc::limit_violation);
  EXPECT_TRUE(contains(e, "sweeps"));
  EXPECT_NO_THROW(g.check_move(Axis::receive, -60, -80, 45.0));  // stays on one side
  // Around the far side (transmission): 340° of sum is 20° from a full turn.
  EXPECT_NO_THROW(g.check_move(Axis::receive, 150, 290, 50.0));
  EXPECT_THROW(g.check_move(Axis::receive, 150, 310, 50.0), Error);
}

TEST(MotionGuard, BothArmsMovingChecksEveryInterleaving) {
  MotionGuard g(10);
  // (i, r): (45, 30) -> (20, 60). Sums span [20+30, 45+60] = [50, 105]: safe.
  EXPECT_NO_THROW(g.check_arms(45, 20, 30, 60));
  // (60, -20) -> (20, 10): moving the source first reaches (20, −20), 0° apart.
  EXPECT_THROW(g.check_arms(60, 20, -20, 10), Error);
  // The same end points in the other interleaving would be safe, but the guard cannot
  // know the order: it must reject.
  EXPECT_NO_THROW(g.check_arms(60, 60, -20, 10));
  EXPECT_NO_THROW(g.check_arms(60, 20, 10, 10));
  EXPECT_THROW(MotionGuard(180), Error);
  EXPECT_THROW(MotionGuard(-1), Error);
}
