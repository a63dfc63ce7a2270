// The registry's one guard: open_instrument wraps the motion controller in a GuardedMotion
// built from the limits table, whose unset minimum separation is the mock's profile
// clearance with the mock and kDefaultMinSeparationDeg with any other motion driver.
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/registry/registry.hpp"

using gonio::Errc;
using gonio::Error;
using namespace gonio::drivers;
using nlohmann::json;
using namespace std::chrono_literals;

namespace {

const json kMock{{"motion", {{"driver", "mock"}}}, {"photometer", {{"driver", "mock"}}}};

}  // namespace

TEST(RegistryGuard, OpenInstrumentGuardsTheMotionWithTheLimitsTable) {
  MotionLimits limits;
  limits.incidence_max = 60;
  limits.min_separation = 12;
  auto inst = open_instrument(kMock, limits);
  ASSERT_NE(inst.motion, nullptr);
  EXPECT_DOUBLE_EQ(inst.motion->guard().min_separation_deg(), 12);
  EXPECT_EQ(*inst.motion->guard().limits(Axis::incidence), (SoftLimits{0, 60}));
  try {
    inst.motion->move(Axis::incidence, 70, 1s);
    FAIL() << "a move beyond the table's limit was forwarded";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::limit_violation);
    EXPECT_EQ(e.field(), "incidence");
  }
  EXPECT_DOUBLE_EQ(inst.motion->position(Axis::incidence, 1s), 0);  // the lab never moved
  // The mock's arms rest at incidence 0°, receive 45°: receive to −5° leaves them 5° apart.
  EXPECT_THROW(inst.motion->move(Axis::receive, -5, 1s), Error);
  EXPECT_DOUBLE_EQ(inst.motion->position(Axis::receive, 1s), 45);
  inst.motion->move(Axis::receive, 20, 1s);
  EXPECT_DOUBLE_EQ(inst.motion->position(Axis::receive, 1s), 20);
}

TEST(RegistryGuard, UnsetSeparationTakesTheDriversDefault) {
  // The mock: its profile's clearance (gcms4: 10°).
  EXPECT_DOUBLE_EQ(motion_guard(MotionLimits{}, kMock["motion"]).min_separation_deg(), 10);
  // Any other motion driver: the documented default; its config is not opened.
  const json modbus{{"driver", "modbus"}, {"links", json::object()}};
  EXPECT_DOUBLE_EQ(motion_guard(MotionLimits{}, modbus).min_separation_deg(),
                   kDefaultMinSeparationDeg);
  MotionLimits set;
  set.min_separation = 3;
  EXPECT_DOUBLE_EQ(motion_guard(set, modbus).min_separation_deg(), 3);
  // A guard handed in is the one used.
  MotionGuard g(7);
  auto inst = open_instrument(kMock, g);
  EXPECT_DOUBLE_EQ(inst.motion->guard().min_separation_deg(), 7);
}

TEST(RegistryGuard, BadMockConfigNamesTheMotionField) {
  const json bad{{"driver", "mock"}, {"time_scale", 99}};
  try {
    (void)motion_guard(MotionLimits{}, bad);
    FAIL() << "a bad mock config was accepted";
  } catch (const Error& e) {
    // As open_instrument names it.
    EXPECT_EQ(e.code(), Errc::out_of_range);
    EXPECT_EQ(e.field().rfind("motion.", 0), 0u) << e.field();
    EXPECT_NE(e.field().find("time_scale"), std::string::npos) << e.field();
  }
}
