// Plan check tests: a good plan passes; soft limits, arm separation, the swept path between
// consecutive geometries, missing axes and the photometer's range are each rejected with
// Error(plan_rejected) naming the geometry or the wavelengths and the limit.
#include <string>

#include <gtest/gtest.h>

#include "gonio/daemon/instrument/plan_check.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {
namespace {

using drivers::Axis;
using drivers::MotionGuard;

// Minimum separation 10°, incidence within [0°, 80°], receive within [−85°, 85°].
MotionGuard guard() {
  MotionGuard g(10);
  g.set_limits(Axis::incidence, {0, 80});
  g.set_limits(Axis::receive, {-85, 85});
  return g;
}

const DeviceFacts kArms{{Axis::incidence, Axis::receive}, WavelengthGrid::parse("400:700:10"), std::nullopt};

ScanPlan plan_of(std::vector<Geometry> geometries) {
  ScanPlan p;
  p.geometries = std::move(geometries);
  return p;
}

Error rejection(const ScanPlan& plan, const DeviceFacts& facts = kArms) {
  try {
    check_plan(plan, guard(), facts);
  } catch (const Error& e) {
    return e;
  }
  ADD_FAILURE() << "the plan was accepted";
  return Error(Errc::internal, "accepted");
}

bool mentions(const Error& e, const std::string& text) {
  return std::string(e.what()).find(text) != std::string::npos;
}

TEST(PlanCheck, AGoodPlanPasses) {
  const auto plan = plan_of({Geometry::in_plane(45, 0), Geometry::in_plane(45, 30),
                             Geometry::in_plane(45, 60), Geometry::in_plane(30, 60),
                             Geometry::in_plane(60, -30), Geometry::in_plane(80, -60)});
  EXPECT_NO_THROW(check_plan(plan, guard(), kArms));
  EXPECT_NO_THROW(check_plan(plan, guard(), DeviceFacts{}));  // devices not opened yet
}

TEST(PlanCheck, SoftLimitsNameTheGeometryAndTheLimit) {
  std::vector<Geometry> g(12, Geometry::in_plane(45, 0));
  g.push_back(Geometry::in_plane(45, -88));
  const auto e = rejection(plan_of(g));
  EXPECT_EQ(e.code(), Errc::plan_rejected);
  EXPECT_EQ(e.field(), "geometries[12]");
  EXPECT_TRUE(mentions(e, "geometries[12]")) << e.what();
  EXPECT_TRUE(mentions(e, "receive")) << e.what();
  EXPECT_TRUE(mentions(e, "85")) << e.what();

  const auto i = rejection(plan_of({Geometry::in_plane(30, 0), Geometry::in_plane(85, 0)}));
  EXPECT_EQ(i.code(), Errc::plan_rejected);
  EXPECT_EQ(i.field(), "geometries[1]");
  EXPECT_TRUE(mentions(i, "incidence")) << i.what();
  EXPECT_TRUE(mentions(i, "80")) << i.what();
}

TEST(PlanCheck, ArmsCloserThanTheMinimumSeparationAreRejected) {
  // θi = 45°, θr = −40°: the arms are 5° apart.
  const auto e = rejection(plan_of({Geometry::in_plane(45, 0), Geometry::in_plane(45, -40)}));
  EXPECT_EQ(e.code(), Errc::plan_rejected);
  EXPECT_EQ(e.field(), "geometries[1]");
  EXPECT_TRUE(mentions(e, "5° apart")) << e.what();
  EXPECT_TRUE(mentions(e, "minimum separation 10°")) << e.what();
}

TEST(PlanCheck, APathThroughTheCollisionZoneIsRejectedEvenWhenBothEndsAreClear) {
  // (10°, 20°) is 30° apart and (30°, −50°) 20° apart, but moving either arm first sweeps
  // θi + θr through 0.
  const auto a = Geometry::in_plane(10, 20), b = Geometry::in_plane(30, -50);
  EXPECT_NO_THROW(check_plan(plan_of({a}), guard(), kArms));
  EXPECT_NO_THROW(check_plan(plan_of({b}), guard(), kArms));
  const auto e = rejection(plan_of({a, b}));
  EXPECT_EQ(e.code(), Errc::plan_rejected);
  EXPECT_EQ(e.field(), "geometries[1]");
  EXPECT_TRUE(mentions(e, "cannot move here from")) << e.what();
  EXPECT_TRUE(mentions(e, "minimum separation 10°")) << e.what();
  // A path that only one order keeps clear is accepted, whichever order that is.
  // (5°, 40°) → (40°, −25°): incidence first keeps θi + θr within 15°..80°; receive first
  // (at θi = 5°) would sweep −20°..45°.
  const auto c = Geometry::in_plane(5, 40), d = Geometry::in_plane(40, -25);
  EXPECT_NO_THROW(check_plan(plan_of({c, d}), guard(), kArms));
  // And back: only receive first is clear.
  EXPECT_NO_THROW(check_plan(plan_of({d, c}), guard(), kArms));
}

TEST(PlanCheck, OutOfPlaneAndAzimuthNeedTheAxes) {
  const auto tilt = rejection(plan_of({Geometry::in_plane(45, 0), Geometry{45, 10, 0, 0}}));
  EXPECT_EQ(tilt.code(), Errc::plan_rejected);
  EXPECT_EQ(tilt.field(), "geometries[1]");
  EXPECT_TRUE(mentions(tilt, "tilt axis")) << tilt.what();

  const auto azimuth = plan_of({Geometry{45, 30, 0, 30}});
  const auto e = rejection(azimuth);
  EXPECT_EQ(e.field(), "geometries[0]");
  EXPECT_TRUE(mentions(e, "rotation axis")) << e.what();
  auto with_rotation = kArms;
  with_rotation.axes.push_back(Axis::rotation);
  EXPECT_NO_THROW(check_plan(azimuth, guard(), with_rotation));
  EXPECT_NO_THROW(check_plan(azimuth, guard(), DeviceFacts{}));  // axes not known yet
}

TEST(PlanCheck, WavelengthsMustLieWithinThePhotometers) {
  auto plan = plan_of({Geometry::in_plane(45, 0)});
  plan.wavelengths = WavelengthGrid::parse("350:700:10");
  const auto e = rejection(plan);
  EXPECT_EQ(e.code(), Errc::plan_rejected);
  EXPECT_EQ(e.field(), "wavelengths");
  EXPECT_TRUE(mentions(e, "400–700 nm")) << e.what();
  plan.wavelengths = WavelengthGrid::parse("400:720:10");
  EXPECT_EQ(rejection(plan).field(), "wavelengths");
  plan.wavelengths = WavelengthGrid::parse("400:700:5");  // finer, same range: fine
  EXPECT_NO_THROW(check_plan(plan, guard(), kArms));
  plan.wavelengths = WavelengthGrid::parse("350:700:10");
  EXPECT_NO_THROW(check_plan(plan, guard(), DeviceFacts{{Axis::incidence, Axis::receive}, {}, std::nullopt}));
}

TEST(PlanCheck, TheFirstGeometryIsOnTheArmsSideOfTheZone) {
  // The arms at 0°/45° can never reach 45°/−80° (sum −35°): the receive arm would pass the
  // source arm.
  DeviceFacts facts = kArms;
  facts.arms = Geometry::in_plane(0, 45);
  const auto e = rejection(plan_of({Geometry::in_plane(45, -80), Geometry::in_plane(45, -60)}), facts);
  EXPECT_EQ(e.code(), Errc::plan_rejected);
  EXPECT_EQ(e.field(), "geometries[0]");
  EXPECT_TRUE(mentions(e, "45/-80")) << e.what();
  EXPECT_TRUE(mentions(e, "other side of the collision zone from the arms, which stand at 0/45")) << e.what();
  // Without the arms' position, the plan is consistent on its own.
  EXPECT_NO_THROW(check_plan(plan_of({Geometry::in_plane(45, -80), Geometry::in_plane(45, -60)}), guard(), kArms));
}

TEST(PlanCheck, AnAdaptivePlansEveryCandidateIsReachable) {
  // Candidates on both sides of the zone: any order would have to cross it.
  auto plan = plan_of({Geometry::in_plane(45, -35), Geometry::in_plane(45, 0), Geometry::in_plane(45, -80)});
  plan.adaptive = AdaptivePlan{};
  auto e = rejection(plan);
  EXPECT_EQ(e.field(), "geometries[2]");
  EXPECT_TRUE(mentions(e, "45/-80")) << e.what();
  EXPECT_TRUE(mentions(e, "other side of the collision zone from geometries[0] (45/-35)")) << e.what();
  // A candidate inside the zone is refused as in a plain plan.
  plan.geometries = {Geometry::in_plane(45, 0), Geometry::in_plane(45, -40)};
  e = rejection(plan);
  EXPECT_EQ(e.field(), "geometries[1]");
  EXPECT_TRUE(mentions(e, "inside the collision zone")) << e.what();
  // One side, in any order: accepted.
  plan.geometries = {Geometry::in_plane(45, 80), Geometry::in_plane(45, -35), Geometry::in_plane(30, 0)};
  DeviceFacts facts = kArms;
  facts.arms = Geometry::in_plane(0, 45);
  EXPECT_NO_THROW(check_plan(plan, guard(), facts));
  // All on the far side of the arms: refused at the first.
  plan.geometries = {Geometry::in_plane(45, -80), Geometry::in_plane(45, -60)};
  e = rejection(plan, facts);
  EXPECT_EQ(e.field(), "geometries[0]");
}

}  // namespace
}  // namespace gonio::daemon
