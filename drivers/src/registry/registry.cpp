// The static driver table and the instrument factory (registry.hpp).
#include "gonio/registry/registry.hpp"

#include <algorithm>
#include <array>
#include <cmath>
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

SideCheck check_of(const MotionController& m) {
  SideCheck out;
  out.axes = m.axes();
  for (Axis a : out.axes)
    if (const auto h = m.home_position(a)) out.home.emplace_back(a, *h);
  return out;
}

SideCheck check_modbus(const nlohmann::json& c) {
  const auto cfg = modbus::MotionConfig::from_json(c);
  // The controller opens its links at its first call: building it checks what libmodbus
  // accepts of the link settings without sending a byte.
  auto out = check_of(*make_modbus_motion(cfg));
  for (const auto& l : cfg.links) {
    const auto link = "motion.links." + l.name;
    if (l.kind == modbus::LinkConfig::Kind::rtu)
      out.devices.push_back({DeviceRef::Kind::path, link + ".device", l.device});
    else
      out.devices.push_back({DeviceRef::Kind::tcp, link + ".host", fmt::format("{}:{}", l.host, l.port)});
  }
  return out;
}
// The mock is a simulation: building it opens nothing.
SideCheck check_mock_motion(const nlohmann::json& c) { return check_of(*mock::make_mock_motion(c)); }
SideCheck check_mock_photometer(const nlohmann::json& c) {
  (void)mock::make_mock_photometer(c);
  return {};
}
SideCheck check_scpi(std::string_view transport, const nlohmann::json& c) {
  auto device = scpi::check_photometer(transport, c);
  device.field = join_field("photometer", device.field);
  return {{}, {}, {device}};
}
SideCheck check_scpi_serial(const nlohmann::json& c) { return check_scpi("serial", c); }
SideCheck check_scpi_tcp(const nlohmann::json& c) { return check_scpi("tcp", c); }
SideCheck check_scpi_usbtmc(const nlohmann::json& c) { return check_scpi("usbtmc", c); }

const std::array kDrivers{
    DriverInfo{.name = "modbus",
               .description = "Modbus RTU/TCP motion controllers (Oriental Motor AZ preset)",
               .motion = true,
               .make_motion = &modbus_motion,
               .check_motion = &check_modbus},
    DriverInfo{.name = "mock",
               .description = "virtual lab driven by the twin (no hardware)",
               .motion = true,
               .photometer = true,
               .needs_hardware = false,
               .make_motion = &mock::make_mock_motion,
               .make_photometer = &mock::make_mock_photometer,
               .default_min_separation = &mock::default_min_separation,
               .check_motion = &check_mock_motion,
               .check_photometer = &check_mock_photometer},
    DriverInfo{.name = "scpi-serial",
               .description = "SCPI photometer on a serial line",
               .photometer = true,
               .make_photometer = &scpi_serial,
               .check_photometer = &check_scpi_serial},
    DriverInfo{.name = "scpi-tcp",
               .description = "SCPI photometer on a raw TCP socket",
               .photometer = true,
               .make_photometer = &scpi_tcp,
               .check_photometer = &check_scpi_tcp},
    DriverInfo{.name = "scpi-usbtmc",
               .description = "SCPI photometer over USBTMC (libusb)",
               .photometer = true,
               .make_photometer = &scpi_usbtmc,
               .check_photometer = &check_scpi_usbtmc},
};

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

// The widest in-plane angle between the arms over the limits rectangle: their separation is
// |θi + θr| wrapped into [0°, 180°] (collision.hpp), and θi + θr covers [lo, hi].
double widest_separation(double lo, double hi) {
  if (hi - lo >= 360) return 180;
  const double k = std::ceil((lo - 180) / 360);
  if (180 + 360 * k <= hi) return 180;
  return std::max(MotionGuard::arm_separation(lo, 0), MotionGuard::arm_separation(hi, 0));
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

InstrumentCheck check_instrument(const nlohmann::json& config, const MotionLimits& limits) {
  json_util::ObjectReader r(config, "");
  const auto* m = r.raw("motion");
  const auto* p = r.raw("photometer");
  r.finish();
  if (m == nullptr) throw Error::invalid("motion", "is required");
  if (p == nullptr) throw Error::invalid("photometer", "is required");
  auto motion_split = split(*m, "motion");
  auto photometer_split = split(*p, "photometer");
  InstrumentCheck out;
  out.motion_driver = motion_split.first;
  out.photometer_driver = photometer_split.first;
  const nlohmann::json mcfg = std::move(motion_split.second);
  const nlohmann::json pcfg = std::move(photometer_split.second);

  const auto named = [](const std::string& field, const std::string& name) -> const DriverInfo& {
    try {
      return find_driver(name);
    } catch (const Error& e) {
      throw Error(e.code(), fmt::format("{}: {}", field, e.what()), field);
    }
  };
  const auto& md = named("motion.driver", out.motion_driver);
  const auto& pd = named("photometer.driver", out.photometer_driver);
  if (!md.check_motion)
    throw Error::invalid("motion.driver", fmt::format("'{}' has no motion side", out.motion_driver));
  if (!pd.check_photometer)
    throw Error::invalid("photometer.driver", fmt::format("'{}' has no photometer side", out.photometer_driver));
  out.motion = prefixed("motion", [&] { return md.check_motion(mcfg); });
  if (out.motion_driver == "mock" && out.photometer_driver == "mock") {
    if (!pcfg.empty())
      throw Error::invalid("photometer", "a mock photometer shares the motion side's lab: "
                                         "configure it under \"motion\"");
  } else {
    out.photometer = prefixed("photometer", [&] { return pd.check_photometer(pcfg); });
  }

  const MotionGuard guard = motion_guard(limits, *m);
  out.min_separation = guard.min_separation_deg();
  for (Axis arm : {Axis::incidence, Axis::receive})
    if (std::find(out.motion.axes.begin(), out.motion.axes.end(), arm) == out.motion.axes.end())
      throw Error::invalid("motion.axes", fmt::format("the motion driver has no '{}' axis: scans "
                                                      "move both arms, incidence and receive",
                                                      to_text(arm)));
  for (const auto& [axis, deg] : out.motion.home) {
    const auto lim = limits.of(axis);
    if (!(deg >= lim.min_deg && deg <= lim.max_deg))
      throw Error(Errc::out_of_range,
                  fmt::format("limits.{}: homing ends the axis at {}°, outside [{}, {}]°: the "
                              "guard would refuse to home it",
                              to_text(axis), deg, lim.min_deg, lim.max_deg),
                  fmt::format("limits.{}", to_text(axis)));
  }
  const double widest = widest_separation(limits.incidence_min + limits.receive_min,
                                          limits.incidence_max + limits.receive_max);
  if (widest < out.min_separation)
    throw Error(Errc::out_of_range,
                fmt::format("limits.min_separation = {}° is wider than any position within "
                            "limits.incidence [{}, {}]° and limits.receive [{}, {}]° allows "
                            "(at most {}°): every geometry would be refused",
                            out.min_separation, limits.incidence_min, limits.incidence_max,
                            limits.receive_min, limits.receive_max, widest),
                "limits.min_separation");
  return out;
}

}  // namespace gonio::drivers
