// The driver registry — a static table of every driver by name with its capabilities
// (docs/architecture.md §4: the mock is a driver like any other).
//
//   name          motion  photometer  what
//   modbus        yes     -           Modbus RTU/TCP motion controllers (modbus/modbus_motion.hpp)
//   mock          yes     yes         the twin-backed virtual lab (sim/mock/mock.hpp)
//   scpi-serial   -       yes         SCPI photometer on a serial line (transport/serial.hpp)
//   scpi-tcp      -       yes         SCPI photometer on a raw TCP socket (transport/tcp.hpp)
//   scpi-usbtmc   -       yes         SCPI photometer over USBTMC via libusb (usbtmc/usbtmc.hpp)
//
// Instrument config (JSON, strict): {"motion": {"driver": NAME, ...driver keys},
// "photometer": {"driver": NAME, ...driver keys}}. When both sides are "mock", the lab is
// configured on the motion side and the photometer side must be just {"driver": "mock"}:
// both then share one virtual lab (the photometer sees where the arms are).
//
// Motion safety is defined once: open_instrument wraps the motion controller in a
// GuardedMotion whose MotionGuard comes from the instrument's one limits table
// (MotionLimits, goniod's [instrument.limits]). Drivers hold no limits of their own. An
// unset min_separation takes the motion driver's default: the mock lab's profile clearance
// for "mock", kDefaultMinSeparationDeg (motion/limits.hpp) for every other driver.
//
// check_instrument reads the same config as open_instrument, with the same errors, and
// opens nothing: it is what `goniod --check-config` runs.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "gonio/drivers/motion/guarded_motion.hpp"
#include "gonio/drivers/motion/limits.hpp"
#include "gonio/drivers/motion/motion_controller.hpp"
#include "gonio/drivers/photometer/photometer.hpp"
#include "gonio/drivers/transport/transport.hpp"

namespace gonio::drivers {

// What one side's driver config gives, found without opening a device.
struct SideCheck {
  std::vector<Axis> axes;                     // motion: the axes the controller drives
  std::vector<std::pair<Axis, double>> home;  // motion: where homing ends, where the driver knows
  std::vector<DeviceRef> devices;             // what the driver would open
};

struct DriverInfo {
  std::string_view name;
  std::string_view description;
  bool motion = false;         // provides a MotionController
  bool photometer = false;     // provides a Photometer
  bool needs_hardware = true;  // false: runs without devices (mock)
  std::unique_ptr<MotionController> (*make_motion)(const nlohmann::json& config) = nullptr;
  std::unique_ptr<Photometer> (*make_photometer)(const nlohmann::json& config) = nullptr;
  // The minimum arm separation when the limits table sets none (nullptr:
  // kDefaultMinSeparationDeg).
  double (*default_min_separation)(const nlohmann::json& config) = nullptr;
  // Read the side's config as make_motion / make_photometer do, with the same errors, and
  // open nothing (set for every side the driver provides).
  SideCheck (*check_motion)(const nlohmann::json& config) = nullptr;
  SideCheck (*check_photometer)(const nlohmann::json& config) = nullptr;
};

std::span<const DriverInfo> drivers() noexcept;
// Throws Error(not_found) listing the known names.
const DriverInfo& find_driver(std::string_view name);

// `config` holds the driver's own keys (no "driver" key). Throws Error(unsupported) when
// the driver has no such side. The controller is the bare driver, unguarded: instruments
// come from open_instrument.
std::unique_ptr<MotionController> make_motion(std::string_view driver, const nlohmann::json& config);
std::unique_ptr<Photometer> make_photometer(std::string_view driver, const nlohmann::json& config);

// The guard of an instrument whose motion side is `motion` ({"driver": NAME, ...}): the
// limits of `limits`, its min_separation or else the driver's default. Errors name the
// field ("motion.profile", "min_separation", ...).
MotionGuard motion_guard(const MotionLimits& limits, const nlohmann::json& motion);

namespace mock {
class Lab;
}

struct Instrument {
  std::unique_ptr<GuardedMotion> motion;
  std::unique_ptr<Photometer> photometer;
};

// Opens the sides of an instrument one at a time, and again after a side was dropped (a
// device that went away: a USB replug, a device rebooted): the same driver tables, the
// motion controller always wrapped in a GuardedMotion with the same guard, and with the
// mock the same virtual lab, so that a reconnection finds the lab as it left it. The
// constructor checks the tables' shape (sides, driver names); the drivers' own keys are
// checked by the first open of each side. Errors name the field ("motion.driver", ...).
class InstrumentOpener {
 public:
  InstrumentOpener(const nlohmann::json& config, const MotionGuard& guard);
  ~InstrumentOpener();
  InstrumentOpener(const InstrumentOpener&) = delete;
  InstrumentOpener& operator=(const InstrumentOpener&) = delete;

  std::unique_ptr<GuardedMotion> open_motion();
  std::unique_ptr<Photometer> open_photometer();
  const MotionGuard& guard() const noexcept { return guard_; }

 private:
  std::shared_ptr<mock::Lab> lab();  // both sides mock: the one lab, built at first use

  MotionGuard guard_;
  std::string motion_driver_, photometer_driver_;
  nlohmann::json motion_config_, photometer_config_;  // without "driver"
  std::shared_ptr<mock::Lab> lab_;
};
// From the instrument config above, the motion controller wrapped in a GuardedMotion with
// `guard`; errors name the field ("motion.driver", ...).
Instrument open_instrument(const nlohmann::json& config, const MotionGuard& guard);
// The same, with the guard of `limits` (motion_guard).
Instrument open_instrument(const nlohmann::json& config, const MotionLimits& limits = {});

struct InstrumentCheck {
  std::string motion_driver, photometer_driver;
  double min_separation = 0;  // in effect: the limits table's or the motion driver's default
  SideCheck motion, photometer;
};
// The instrument config above and `limits` checked as open_instrument would take them, plus
// the agreement of the limits with the motion driver: the arms (incidence and receive) are
// among its axes, every home position it knows lies within its axis's limits, and some
// position within the limits keeps the arms min_separation apart. Opens nothing; errors
// name the field ("motion.links.bus.baud", "limits.receive", "limits.min_separation").
InstrumentCheck check_instrument(const nlohmann::json& config, const MotionLimits& limits);

}  // namespace gonio::drivers
