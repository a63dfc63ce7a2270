// The static driver table and the instrument factory (registry.hpp).
#include "gonio/registry/registry.hpp"

#include <array>
#include <tuple>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/sim/mock/mock.hpp"
#include "gonio/drivers/modbus/modbus_motion.hpp"
#include "gonio/drivers/scpi/scpi.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio::drivers {
namespace {

std::unique_ptr<MotionController> modbus_motion(const nlohmann::json& c) { return make_modbus_motion(c); }
std::unique_ptr<Photometer> scpi_serial(const nlohmann::json& c) { return scpi::make_photometer("serial", c); }
std::unique_ptr<Photometer> scpi_tcp(const nlohmann::json& c) { return scpi::make_photometer("tcp", c); }
std::unique_ptr<Photometer> scpi_usbtmc(const nlohmann::json& c) { return scpi::make_photometer("usbtmc", c); }

const std::array<DriverInfo, 5> kDrivers{{
    {"modbus", "Modbus RTU/TCP motion controllers (Oriental Motor AZ preset)", true, false, true,
     &modbus_motion, nullptr},
    {"mock", "virtual lab driven by the twin (no hardware)", true, true, false,
     &mock::make_mock_motion, &mock::make_mock_photometer, &mock::default_min_separation},
    {"scpi-serial", "SCPI photometer on a serial line", false, true, true, nullptr, &scpi_serial},
    {"scpi-tcp", "SCPI photometer on a raw TCP socket", false, true, true, nullptr, &scpi_tcp},
    {"scpi-usbtmc", "SCPI photometer over USBTMC (libusb)", false, true, true, nullptr, &scpi_usbtmc},
}};

std::string names() {
  std::string s;
  for (const auto& d : kDrivers) s += (s.empty() ? "" : ", ") + std::string(d.name);
  return s;
}

// Invalid config values get the side's name in front of their field ("motion.seed").
template <typename F>
auto prefixed(const std::string& prefix, F&& f) {
  try {
    return f();
  } catch (const Error& e) {
    if (e.code() == Errc::invalid_argument || e.code() == Errc::out_of_range)
      throw json_util::prefixed(e, prefix);
    throw;
  }
}

// Splits {"driver": X, ...rest}.
std::pair<std::string, nlohmann::json> split(const nlohmann::json& side, const std::string& field) {
  if (!side.is_object()) throw Error::invalid(field, "expected an object with a \"driver\" key");
  const auto it = side.find("driver");
  if (it == side.end()) throw Error::invalid(join_field(field, "driver"), "is required");
  auto name = json_util::get_as<std::string>(*it, join_field(field, "driver"));
  nlohmann::json rest = side;
  rest.erase("driver");
  return {name, rest};
}

}  // namespace

std::span<const DriverInfo> drivers() noexcept { return kDrivers; }

const DriverInfo& find_driver(std::string_view name) {
  for (const auto& d : kDrivers)
    if (d.name == name) return d;
  throw Error(Errc::not_found, fmt::format("no driver '{}' (known: {})", name, names()));
}

std::unique_ptr<MotionController> make_motion(std::string_view driver, const nlohmann::json& config) {
  const auto& d = find_driver(driver);
  if (!d.make_motion) throw Error(Errc::unsupported, fmt::format("driver '{}' has no motion side", driver));
  return d.make_motion(config);
}

std::unique_ptr<Photometer> make_photometer(std::string_view driver, const nlohmann::json& config) {
  const auto& d = find_driver(driver);
  if (!d.make_photometer)
    throw Error(Errc::unsupported, fmt::format("driver '{}' has no photometer side", driver));
  return d.make_photometer(config);
}

MotionGuard motion_guard(const MotionLimits& limits, const nlohmann::json& motion) {
  if (limits.min_separation) return limits.guard(*limits.min_separation);
  const auto side = split(motion, "motion");
  const nlohmann::json& cfg = side.second;
  const auto& d = find_driver(side.first);
  const double sep = d.default_min_separation
                         ? prefixed("motion", [&] { return d.default_min_separation(cfg); })
                         : kDefaultMinSeparationDeg;
  return limits.guard(sep);
}

Instrument open_instrument(const nlohmann::json& config, const MotionLimits& limits) {
  json_util::ObjectReader r(config, "");
  const auto* m = r.raw("motion");
  if (m == nullptr) throw Error::invalid("motion", "is required");
  return open_instrument(config, motion_guard(limits, *m));
}

InstrumentOpener::InstrumentOpener(const nlohmann::json& config, const MotionGuard& guard)
    : guard_(guard) {
  json_util::ObjectReader r(config, "");
  const auto* m = r.raw("motion");
  const auto* p = r.raw("photometer");
  r.finish();
  if (m == nullptr) throw Error::invalid("motion", "is required");
  if (p == nullptr) throw Error::invalid("photometer", "is required");
  std::tie(motion_driver_, motion_config_) = split(*m, "motion");
  std::tie(photometer_driver_, photometer_config_) = split(*p, "photometer");
  if (motion_driver_ == "mock" && photometer_driver_ == "mock") {
    if (!photometer_config_.empty())
      throw Error::invalid("photometer", "a mock photometer shares the motion side's lab: "
                                         "configure it under \"motion\"");
    return;
  }
  const auto& md = find_driver(motion_driver_);
  const auto& pd = find_driver(photometer_driver_);
  if (!md.make_motion)
    throw Error::invalid("motion.driver", fmt::format("'{}' has no motion side", motion_driver_));
  if (!pd.make_photometer)
    throw Error::invalid("photometer.driver",
                         fmt::format("'{}' has no photometer side", photometer_driver_));
}

InstrumentOpener::~InstrumentOpener() = default;

std::shared_ptr<mock::Lab> InstrumentOpener::lab() {
  if (!lab_) lab_ = prefixed("motion", [&] { return mock::make_mock(motion_config_).lab; });
  return lab_;
}

std::unique_ptr<GuardedMotion> InstrumentOpener::open_motion() {
  std::unique_ptr<MotionController> m;
  if (motion_driver_ == "mock" && photometer_driver_ == "mock")
    m = mock::connect_motion(lab());
  else
    m = prefixed("motion", [&] { return find_driver(motion_driver_).make_motion(motion_config_); });
  return std::make_unique<GuardedMotion>(std::move(m), guard_);
}

std::unique_ptr<Photometer> InstrumentOpener::open_photometer() {
  if (motion_driver_ == "mock" && photometer_driver_ == "mock") return mock::connect_photometer(lab());
  return prefixed("photometer",
                  [&] { return find_driver(photometer_driver_).make_photometer(photometer_config_); });
}

Instrument open_instrument(const nlohmann::json& config, const MotionGuard& guard) {
  InstrumentOpener opener(config, guard);
  Instrument out;
  out.motion = opener.open_motion();
  out.photometer = opener.open_photometer();
  return out;
}

}  // namespace gonio::drivers
