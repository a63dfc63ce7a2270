// ArmClearance: the arms' separation, swept paths, the order of a move and the sides of the
// collision zone — the rule the motion guard, goniod's plan check and the planners share.
#include <gtest/gtest.h>

#include "gonio/proto/arms.hpp"
#include "gonio/proto/error.hpp"

namespace gonio {
namespace {

const ArmClearance kArms(10);

TEST(ArmClearance, SeparationIsTheInPlaneAngleBetweenTheArms) {
  EXPECT_DOUBLE_EQ(ArmClearance::separation(45, 45), 90);
  EXPECT_DOUBLE_EQ(ArmClearance::separation(45, -45), 0);  // retro-reflection
  EXPECT_DOUBLE_EQ(ArmClearance::separation(10, 180), 170);
  EXPECT_DOUBLE_EQ(ArmClearance::separation(30, 320), 10);
  EXPECT_TRUE(kArms.clear(Geometry::in_plane(45, -35)));
  EXPECT_FALSE(kArms.clear(Geometry::in_plane(45, -40)));
  EXPECT_EQ(kArms.why_not_clear(Geometry::in_plane(45, -35)), "");
  EXPECT_NE(kArms.why_not_clear(Geometry::in_plane(45, -40)).find("5° apart"), std::string::npos);
  EXPECT_TRUE(ArmClearance(0).clear(Geometry::in_plane(45, -45)));
  EXPECT_THROW(ArmClearance(180), Error);
  EXPECT_THROW(ArmClearance(-1), Error);
}

TEST(ArmClearance, AMoveSweepsEveryAngleOnItsWay) {
  // The receive arm from 45° to −80° with the incidence arm at 0° passes retro-reflection.
  ASSERT_TRUE(kArms.sweep_collision(0, 0, 45, -80));
  EXPECT_DOUBLE_EQ(*kArms.sweep_collision(0, 0, 45, -80), 0);
  EXPECT_FALSE(kArms.sweep_collision(45, 45, -30, 80));
  // Near 360° as well as 0°.
  EXPECT_TRUE(kArms.sweep_collision(170, 170, 150, 200));
  EXPECT_FALSE(ArmClearance(0).sweep_collision(0, 0, 45, -80));
}

TEST(ArmClearance, OneArmAfterTheOtherInWhicheverOrderKeepsClear) {
  const auto a = Geometry::in_plane(0, 45), b = Geometry::in_plane(80, -30);
  // Incidence first sweeps 0→80 at +45 (45…125), then receive 45→−30 at 80 (125…50): clear.
  EXPECT_EQ(kArms.incidence_first(a, b), std::optional<bool>(true));
  // Receive first would pass 0°/−30° (sum −30): only the reverse of the move above works.
  EXPECT_EQ(kArms.incidence_first(b, a), std::optional<bool>(false));
  EXPECT_TRUE(kArms.can_move(a, b));
  // Across the zone: no order helps.
  EXPECT_FALSE(kArms.can_move(Geometry::in_plane(45, -35), Geometry::in_plane(45, -80)));
  EXPECT_FALSE(kArms.can_move(a, Geometry::in_plane(45, -80)));
}

TEST(ArmClearance, GeometriesOnDifferentSidesAreNeverReachable) {
  const auto side = kArms.side(Geometry::in_plane(0, 45));
  ASSERT_TRUE(side);
  EXPECT_EQ(kArms.side(Geometry::in_plane(45, -35)), side);
  EXPECT_EQ(kArms.side(Geometry::in_plane(80, 85)), side);
  EXPECT_NE(kArms.side(Geometry::in_plane(45, -80)), side);
  EXPECT_FALSE(kArms.side(Geometry::in_plane(45, -45)));  // inside the zone
  EXPECT_EQ(ArmClearance(0).side(Geometry::in_plane(45, -80)), ArmClearance(0).side(Geometry::in_plane(0, 45)));
  // Whatever two clear geometries a move can join are on one side.
  for (double r0 = -85; r0 <= 85; r0 += 5)
    for (double r1 = -85; r1 <= 85; r1 += 5) {
      const auto a = Geometry::in_plane(45, r0), b = Geometry::in_plane(30, r1);
      if (kArms.clear(a) && kArms.clear(b) && kArms.can_move(a, b)) {
        EXPECT_EQ(kArms.side(a), kArms.side(b)) << a.to_string() << " → " << b.to_string();
      }
    }
}

}  // namespace
}  // namespace gonio
