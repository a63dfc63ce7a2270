// Arm moves: the order of the moves that keeps the arms clear, and the homing order that
// moves an arm clear of the other's homing path (the mock homes both arms to 0°, where they
// coincide).
#include <gtest/gtest.h>

#include "gonio/daemon/instrument/arm_moves.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {
namespace {

using drivers::Axis;
using drivers::MotionGuard;
using Kind = ArmStep::Kind;

// Minimum separation 10°, incidence within [0°, 80°], receive within [−85°, 85°].
MotionGuard guard() {
  MotionGuard g(10);
  g.set_limits(Axis::incidence, {0, 80});
  g.set_limits(Axis::receive, {-85, 85});
  return g;
}

ArmStep move(Axis a, double deg) { return ArmStep{.kind = Kind::move, .axis = a, .deg = deg}; }
ArmStep home(Axis a, std::optional<double> deg) { return ArmStep{.kind = Kind::home, .axis = a, .deg = deg}; }

const auto kAtZero = [](Axis) { return std::optional<double>(0.0); };

TEST(ArmMoves, IncidenceFirstWhenBothOrdersKeepTheClearance) {
  const AxisPositions at{{Axis::incidence, 30}, {Axis::receive, 30}};
  EXPECT_EQ(arm_moves(guard(), at, 45, 40, std::nullopt),
            (std::vector<ArmStep>{move(Axis::incidence, 45), move(Axis::receive, 40)}));
}

TEST(ArmMoves, ReceiveFirstWhenIncidenceFirstWouldSweepThroughIt) {
  // Incidence 60° → 10° while receive stands at −40°: the sum would pass −30°..20°, through 0.
  const AxisPositions at{{Axis::incidence, 60}, {Axis::receive, -40}};
  EXPECT_EQ(arm_moves(guard(), at, 10, 40, std::nullopt),
            (std::vector<ArmStep>{move(Axis::receive, 40), move(Axis::incidence, 10)}));
}

TEST(ArmMoves, AnAxisAlreadyThereIsNotMovedAndUnknownPositionsMoveBoth) {
  const AxisPositions at{{Axis::incidence, 30}, {Axis::receive, 30}, {Axis::rotation, 5}};
  EXPECT_EQ(arm_moves(guard(), at, 30, 40, 5.0), (std::vector<ArmStep>{move(Axis::receive, 40)}));
  EXPECT_EQ(arm_moves(guard(), {}, 30, 40, 5.0),
            (std::vector<ArmStep>{move(Axis::incidence, 30), move(Axis::receive, 40), move(Axis::rotation, 5)}));
}

TEST(ArmMoves, NeitherOrderKeepingTheClearanceThrowsTheGuardsError) {
  const AxisPositions at{{Axis::incidence, 30}, {Axis::receive, 30}};
  try {
    arm_moves(guard(), at, 30, -28, std::nullopt);
    FAIL() << "moved into the collision zone";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::limit_violation);
  }
}

TEST(ArmMoves, HomingMovesTheHomedArmClearBeforeTheOtherHomesOntoIt) {
  // Both arms home to 0°: the incidence arm homes, then stands 11° out (one degree beyond
  // the minimum separation) while the receive arm homes from 45° to 0°.
  const AxisPositions at{{Axis::incidence, 20}, {Axis::receive, 45}};
  EXPECT_EQ(homing_steps(guard(), at, {Axis::incidence, Axis::receive}, kAtZero),
            (std::vector<ArmStep>{home(Axis::incidence, 0), move(Axis::incidence, 11), home(Axis::receive, 0)}));
}

TEST(ArmMoves, HomingPathsThatKeepTheClearanceNeedNoMove) {
  // Receive homes to 40°, clear of incidence's home at 0°.
  const auto ends = [](Axis a) { return std::optional<double>(a == Axis::receive ? 40.0 : 0.0); };
  const AxisPositions at{{Axis::incidence, 20}, {Axis::receive, 45}};
  EXPECT_EQ(homing_steps(guard(), at, {Axis::incidence, Axis::receive}, ends),
            (std::vector<ArmStep>{home(Axis::incidence, 0), home(Axis::receive, 40)}));
  // An unknown homing end is homed as it stands.
  EXPECT_EQ(homing_steps(guard(), at, {Axis::receive}, [](Axis) { return std::optional<double>(); }),
            (std::vector<ArmStep>{home(Axis::receive, std::nullopt)}));
}

TEST(ArmMoves, HomingThatNoPositionOfTheOtherArmAllowsIsRefusedNamingTheArm) {
  // Receive homes to 0° from 45° with incidence limited to [0°, 5°]: it cannot stand clear.
  MotionGuard g = guard();
  g.set_limits(Axis::incidence, {0, 5});
  const AxisPositions at{{Axis::incidence, 0}, {Axis::receive, 45}};
  try {
    homing_steps(g, at, {Axis::receive}, kAtZero);
    FAIL() << "homed onto the incidence arm";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::limit_violation);
    EXPECT_EQ(e.field(), "receive");
  }
}

}  // namespace
}  // namespace gonio::daemon
