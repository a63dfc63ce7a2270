#include "gonio/proto/geometry.hpp"

#include <cmath>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"

namespace gonio {
namespace {

TEST(Geometry, FrameFollowsDesign) {
  const auto g = Geometry::in_plane(45, 45);  // specular
  const auto wi = g.incident_direction();
  const auto wr = g.receiving_direction();
  EXPECT_NEAR(wi[0], -std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(wi[2], std::sqrt(0.5), 1e-12);
  // Specular: ωr is the mirror image of ωi about the normal.
  EXPECT_NEAR(wr[0], -wi[0], 1e-12);
  EXPECT_NEAR(wr[2], wi[2], 1e-12);
  EXPECT_DOUBLE_EQ(g.aspecular(), 0);
  // Retro-reflection points back to the source.
  const auto retro = Geometry::in_plane(30, -30).receiving_direction();
  const auto src = Geometry::in_plane(30, -30).incident_direction();
  EXPECT_NEAR(retro[0], src[0], 1e-12);
  EXPECT_NEAR(retro[2], src[2], 1e-12);
}

TEST(Geometry, AspecularNamesAndAstmSet) {
  EXPECT_EQ(Geometry::parse("45as15"), Geometry::in_plane(45, 30));
  EXPECT_EQ(Geometry::parse("45as-15"), Geometry::in_plane(45, 60));
  EXPECT_EQ(Geometry::parse("45as110"), Geometry::in_plane(45, -65));
  EXPECT_EQ(Geometry::parse("45/-30"), Geometry::in_plane(45, -30));
  const auto& astm = Geometry::astm_multi_angle();
  ASSERT_EQ(astm.size(), 6u);
  for (const auto& [name, g] : astm) {
    EXPECT_EQ(Geometry::parse(name), g) << name;
    EXPECT_DOUBLE_EQ(g.theta_i, 45);
  }
  EXPECT_THROW(Geometry::parse("45"), Error);
}

TEST(Geometry, TransmissionIsBelowThePlane) {
  const auto g = Geometry::in_plane(30, 150);  // straight through a thin slab
  EXPECT_TRUE(g.is_transmission());
  const auto wr = g.receiving_direction();
  const auto wi = g.incident_direction();
  EXPECT_LT(wr[2], 0);
  EXPECT_NEAR(wr[0], -wi[0], 1e-12);
  EXPECT_NEAR(wr[2], -wi[2], 1e-12);
  EXPECT_FALSE(Geometry::in_plane(30, 80).is_transmission());
}

TEST(Geometry, ValidationNamesTheField) {
  try {
    Geometry{95, 0, 0, 0}.validate("points[2]");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::out_of_range);
    EXPECT_EQ(e.field(), "points[2].theta_i");
    EXPECT_NE(std::string(e.what()).find("[0, 89.9]"), std::string::npos) << e.what();
  }
  EXPECT_THROW((Geometry{45, 0, 90, 0}.validate()), Error);
  EXPECT_THROW((Geometry{45, 0, 200, 0}.validate()), Error);
  EXPECT_THROW((Geometry{45, 181, 0, 0}.validate()), Error);
}

TEST(Geometry, GridIsCartesianProduct) {
  const auto g = parse_geometry_grid("in=45;out=-80:80:1");
  ASSERT_EQ(g.size(), 161u);
  EXPECT_EQ(g.front(), Geometry::in_plane(45, -80));
  EXPECT_EQ(g.back(), Geometry::in_plane(45, 80));
  const auto h = parse_geometry_grid("in=15,45; as=15,45 ;az-out=0,90");
  ASSERT_EQ(h.size(), 8u);
  EXPECT_EQ(h[1], (Geometry{15, 0, 0, 90}));
  EXPECT_THROW(parse_geometry_grid("in=45"), Error);
  EXPECT_THROW(parse_geometry_grid("in=45;out=1;as=2"), Error);
  try {
    parse_geometry_grid("in=45;out=0;colour=red");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("colour"), std::string::npos);
  }
  try {
    parse_geometry_grid("in=0:100:10;out=0");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "grid[9].theta_i");
  }
}

TEST(Geometry, JsonRoundTripAndStrictness) {
  const Geometry g{45, 10, -30, 90};
  const nlohmann::json j = g;
  EXPECT_EQ(j.get<Geometry>(), g);
  EXPECT_EQ((nlohmann::json{{"theta_i", 45}, {"theta_r", 0}}.get<Geometry>()),
            Geometry::in_plane(45, 0));
  EXPECT_THROW((nlohmann::json{{"theta_i", 45}}.get<Geometry>()), Error);
  EXPECT_THROW((nlohmann::json{{"theta_i", "45"}, {"theta_r", 0}}.get<Geometry>()), Error);
  try {
    nlohmann::json{{"theta_i", 45}, {"theta_r", 0}, {"theta_x", 1}}.get<Geometry>();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "theta_x");
  }
}

}  // namespace
}  // namespace gonio
