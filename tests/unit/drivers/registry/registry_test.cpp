// The registry (drivers/src/registry/registry.cpp). check_instrument: the config
// open_instrument would take, checked without opening a device (every path below is on no
// machine): driver keys with their fields, the devices each side names, and the limits table
// against the motion driver. The one guard: open_instrument wraps the motion controller in a
// GuardedMotion built from the limits table, whose unset minimum separation is the mock's
// profile clearance with the mock and kDefaultMinSeparationDeg with any other motion driver.
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

json hardware() {
  return json::parse(R"({
    "motion": {"driver": "modbus", "register_map": {"preset": "az"},
               "links": {"bus": {"type": "rtu", "device": "/nonexistent/gonio/arms", "baud": 115200,
                                 "format": "8E1"},
                         "net": {"type": "tcp", "host": "192.0.2.7", "port": 502}},
               "axes": {"incidence": {"link": "bus", "unit": 1, "steps_per_degree": 1000, "zero_deg": 5},
                        "receive": {"link": "net", "unit": 2, "steps_per_degree": 1000}}},
    "photometer": {"driver": "scpi-serial", "device": "/nonexistent/gonio/photometer", "baud": 9600}
  })");
}

std::string field_of(const json& config, const MotionLimits& limits = {}) {
  try {
    (void)check_instrument(config, limits);
  } catch (const Error& e) {
    return e.field();
  }
  return "<no error>";
}

const json kMock{{"motion", {{"driver", "mock"}}}, {"photometer", {{"driver", "mock"}}}};

}  // namespace

TEST(RegistryCheck, ListsTheDevicesAxesAndHomesWithoutOpeningThem) {
  MotionLimits limits;
  limits.min_separation = 8;
  const auto c = check_instrument(hardware(), limits);
  EXPECT_EQ(c.motion_driver, "modbus");
  EXPECT_EQ(c.photometer_driver, "scpi-serial");
  EXPECT_DOUBLE_EQ(c.min_separation, 8);
  ASSERT_EQ(c.motion.axes.size(), 2u);
  ASSERT_EQ(c.motion.home.size(), 2u);
  EXPECT_EQ(c.motion.home[0], (std::pair<Axis, double>{Axis::incidence, 5}));
  ASSERT_EQ(c.motion.devices.size(), 2u);
  EXPECT_EQ(c.motion.devices[0].field, "motion.links.bus.device");
  EXPECT_EQ(c.motion.devices[0].kind, DeviceRef::Kind::path);
  EXPECT_EQ(c.motion.devices[0].address, "/nonexistent/gonio/arms");
  EXPECT_EQ(c.motion.devices[1].kind, DeviceRef::Kind::tcp);
  EXPECT_EQ(c.motion.devices[1].address, "192.0.2.7:502");
  ASSERT_EQ(c.photometer.devices.size(), 1u);
  EXPECT_EQ(c.photometer.devices[0].field, "photometer.device");
  EXPECT_EQ(c.photometer.devices[0].address, "/nonexistent/gonio/photometer");
  // open_instrument on the same config does try the devices, and fails on them.
  EXPECT_THROW((void)open_instrument(hardware(), limits), Error);
}

TEST(RegistryCheck, OtherTransportsNameTheirAddress) {
  auto tcp = hardware();
  tcp["photometer"] = {{"driver", "scpi-tcp"}, {"host", "192.0.2.8"}, {"port", 5025}};
  EXPECT_EQ(check_instrument(tcp, {}).photometer.devices.at(0).address, "192.0.2.8:5025");
  auto usb = hardware();
  usb["photometer"] = {{"driver", "scpi-usbtmc"}, {"usb", "1313:8078"}, {"preset", "pm100"},
                       {"wavelengths", "400:700:100"}};
  const auto d = check_instrument(usb, {}).photometer.devices.at(0);
  EXPECT_EQ(d.kind, DeviceRef::Kind::usb);
  EXPECT_EQ(d.field, "photometer.usb");
}

TEST(RegistryCheck, DriverKeysAreCheckedAsTheFactoriesCheckThem) {
  auto c = hardware();
  c["motion"]["links"]["bus"]["baud"] = 7;
  EXPECT_EQ(field_of(c), "motion.links.bus.baud");
  c = hardware();
  c["photometer"]["colour"] = "red";
  EXPECT_EQ(field_of(c), "photometer.colour");
  c = hardware();
  c["photometer"]["driver"] = "scpi-telepathy";
  EXPECT_EQ(field_of(c), "photometer.driver");
  c = hardware();
  c["motion"]["driver"] = "scpi-serial";
  EXPECT_EQ(field_of(c), "motion.driver");
  const json mock{{"motion", {{"driver", "mock"}}}, {"photometer", {{"driver", "mock"}, {"noise", 1}}}};
  EXPECT_EQ(field_of(mock), "photometer");
}

TEST(RegistryCheck, LimitsMustAgreeWithTheMotionDriver) {
  // Homing ends the incidence arm at 5°: a table that starts at 10° would refuse it.
  MotionLimits limits;
  limits.incidence_min = 10;
  EXPECT_EQ(field_of(hardware(), limits), "limits.incidence");
  try {
    (void)check_instrument(hardware(), limits);
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::out_of_range);
    EXPECT_NE(std::string(e.what()).find("[10, 85]"), std::string::npos) << e.what();
  }
  // Both arms within 0..20°: they are never more than 40° apart, so 50° refuses everything.
  limits = {};
  limits.incidence_max = 20;
  limits.receive_min = 0;
  limits.receive_max = 20;
  limits.min_separation = 50;
  EXPECT_EQ(field_of(hardware(), limits), "limits.min_separation");
  limits.min_separation = 40;
  EXPECT_EQ(field_of(hardware(), limits), "<no error>");
  // A separation of 180° is reached only where θi + θr = ±180°.
  limits = {};
  limits.min_separation = 170;
  EXPECT_EQ(field_of(hardware(), limits), "<no error>");  // 85° + 85° = 170°
  limits.receive_max = 80;
  EXPECT_EQ(field_of(hardware(), limits), "limits.min_separation");
  // The scans move both arms.
  auto one_arm = hardware();
  one_arm["motion"]["axes"].erase("receive");
  EXPECT_EQ(field_of(one_arm), "motion.axes");
}

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
