// `gonio-probe modbus-axis`: one axis of a Modbus motion controller, driven through the
// real driver (modbus_motion) so that commissioning exercises exactly the code the
// daemon runs. Options, output and exit codes are documented in modbus_probe.hpp.
#include "gonio/drivers/probe/modbus_probe.hpp"

#include <cmath>
#include <ostream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/drivers/modbus/modbus_motion.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"

namespace gonio::drivers::probe {
namespace {

using modbus::LinkConfig;

constexpr Axis kAxis = Axis::incidence;  // the probe's one axis; never shown to the user

Error usage(const std::string& field, const std::string& message) {
  return Error(Errc::invalid_argument, fmt::format("{}: {}", field, message), field);
}

LinkConfig parse_tcp(const std::string& s) {
  LinkConfig l;
  l.name = "probe";
  l.kind = LinkConfig::Kind::tcp;
  std::string host, port;
  if (!s.empty() && s.front() == '[') {  // [v6addr]:port
    const auto close = s.find(']');
    if (close == std::string::npos || close + 1 >= s.size() || s[close + 1] != ':')
      throw usage("--tcp", fmt::format("'{}' is not HOST:PORT", s));
    host = s.substr(1, close - 1);
    port = s.substr(close + 2);
  } else {
    const auto colon = s.rfind(':');
    if (colon == std::string::npos || colon == 0)
      throw usage("--tcp", fmt::format("'{}' is not HOST:PORT", s));
    host = s.substr(0, colon);
    port = s.substr(colon + 1);
  }
  const long long p = text::parse_int("--tcp port", port);
  if (p < 1 || p > 65535) throw Error::out_of_range("--tcp port", static_cast<double>(p), 1, 65535);
  l.host = host;
  l.port = static_cast<int>(p);
  return l;
}

LinkConfig parse_rtu(const std::string& s) {
  LinkConfig l;
  l.name = "probe";
  l.kind = LinkConfig::Kind::rtu;
  const auto parts = text::split(s, ',');
  if (parts.empty() || parts.size() > 3 || text::trim(parts[0]).empty())
    throw usage("--rtu", fmt::format("'{}' is not DEVICE[,BAUD[,FORMAT]]", s));
  l.device = std::string(text::trim(parts[0]));
  if (parts.size() >= 2) {
    const long long baud = text::parse_int("--rtu baud", text::trim(parts[1]));
    if (baud < 1200 || baud > 4000000)
      throw Error::out_of_range("--rtu baud", static_cast<double>(baud), 1200, 4000000);
    l.baud = static_cast<int>(baud);
  }
  if (parts.size() == 3) modbus::parse_serial_format("--rtu format", std::string(text::trim(parts[2])), l);
  return l;
}

modbus::MotionConfig build_config(const ModbusAxisOptions& o) {
  if (o.tcp.empty() == o.rtu.empty())
    throw usage("--tcp/--rtu", "give exactly one of --tcp HOST:PORT or --rtu DEVICE[,BAUD[,8E1]]");
  modbus::MotionConfig c;
  c.links.push_back(o.tcp.empty() ? parse_rtu(o.rtu) : parse_tcp(o.tcp));
  // 300 ms: a 41-byte frame takes under 50 ms even at 9600 baud 8E1, and controllers
  // answer within milliseconds.
  c.timing.response_timeout = std::chrono::milliseconds(300);
  c.timing.retries = 1;
  c.timing.backoff_initial = std::chrono::milliseconds(100);
  c.timing.backoff_max = std::chrono::milliseconds(1000);
  if (o.unit < 1 || o.unit > 247) throw Error::out_of_range("--unit", o.unit, 1, 247);
  if (!(std::isfinite(o.steps_per_degree) && o.steps_per_degree > 0 && o.steps_per_degree <= 1e7))
    throw Error::out_of_range("--steps-per-degree", o.steps_per_degree, 0.001, 1e7);
  if (!(o.speed_deg_s > 0 && o.speed_deg_s <= 1e4))
    throw Error::out_of_range("--speed", o.speed_deg_s, 0.001, 1e4, "°/s");
  if (o.timeout.count() < 1) throw Error::out_of_range("--timeout", static_cast<double>(o.timeout.count()), 1, 3.6e6);

  modbus::AxisConfig a;
  a.axis = kAxis;
  a.link = "probe";
  a.unit = o.unit;
  a.map = modbus::RegisterMap::preset(o.preset);
  // The device's own range (int32 steps) is the only limit here: the driver refuses
  // targets beyond it.
  a.scale.steps_per_degree = o.steps_per_degree;
  a.speed_deg_s = o.speed_deg_s;
  a.accel_deg_s2 = o.speed_deg_s * 5;
  a.decel_deg_s2 = o.speed_deg_s * 5;
  c.axes.push_back(a);
  if (o.command != "status" && o.command != "home" && o.command != "move")
    throw usage("command", fmt::format("'{}' is not one of status, home, move", o.command));
  if (o.command == "move" && !std::isfinite(o.target_deg))
    throw usage("DEG", "the target must be a finite angle in degrees");
  return c;
}

int exit_code(Errc c) {
  switch (c) {
    case Errc::invalid_argument:
    case Errc::out_of_range:
    case Errc::not_found:
    case Errc::limit_violation: return 2;
    case Errc::disconnected:
    case Errc::io_error: return 3;
    case Errc::timeout: return 4;
    case Errc::protocol_error:
    case Errc::parse_error: return 5;
    case Errc::device_alarm: return 6;
    case Errc::busy: return 7;
    default: return 1;
  }
}

std::string modbus_hint(Errc c) {
  switch (c) {
    case Errc::disconnected:
    case Errc::io_error: return "check the cable, the port or address, and that nothing else holds it";
    case Errc::timeout: return "check the unit id, baud rate and format (AZ default 115200 8E1), and termination";
    case Errc::protocol_error: return "the device answered, but not as an AZ-compatible controller would; check --preset";
    case Errc::device_alarm: return "read the alarm code in the device manual; reset it from the device or the daemon";
    case Errc::busy: return "wait until the axis is at rest, and check that STOP and FREE are off";
    default: return {};
  }
}

// Driver messages start with the internal axis name or the link; the probe speaks of the
// unit on its link.
std::string reword(const std::string& message, const std::string& who, const std::string& link) {
  for (const std::string& prefix : {std::string(to_text(kAxis)) + ": ", link + ": ",
                                    link + " unit "}) {
    if (message.rfind(prefix, 0) != 0) continue;
    std::string rest = message.substr(prefix.size());
    if (prefix.back() == ' ') {  // "<link> unit N: ..."
      const auto colon = rest.find(": ");
      if (colon != std::string::npos) rest = rest.substr(colon + 2);
    }
    return who + ": " + rest;
  }
  return who + ": " + message;
}

}  // namespace

int run_modbus_axis(const ModbusAxisOptions& o, std::ostream& out, std::ostream& err) {
  modbus::MotionConfig cfg;
  try {
    cfg = build_config(o);
  } catch (const Error& e) {
    err << "error: " << e.what() << '\n';
    return 2;
  }
  const std::string who = fmt::format("unit {} on {}", o.unit, cfg.links.front().describe());
  const auto level = spdlog::get_level();
  spdlog::set_level(o.verbose ? spdlog::level::debug : spdlog::level::err);
  int code = 0;
  try {
    auto motion = make_modbus_motion(cfg);
    if (o.command == "home") {
      motion->home(kAxis, o.timeout);
      out << fmt::format("homed: {} at {:.4f}°\n", who, motion->position(kAxis, o.timeout));
    } else if (o.command == "move") {
      motion->move(kAxis, o.target_deg, o.timeout);
      out << fmt::format("moved: {} at {:.4f}° (target {:g}°)\n", who,
                         motion->position(kAxis, o.timeout), o.target_deg);
    } else {
      const AxisStatus s = motion->status(kAxis, o.timeout);
      const auto steps = [&](double deg) { return std::llround(deg * o.steps_per_degree); };
      out << who << '\n'
          << fmt::format("  position  {:.4f}° ({} steps)\n", s.position_deg, steps(s.position_deg))
          << fmt::format("  command   {:.4f}° ({} steps)\n", s.command_deg, steps(s.command_deg))
          << "  state     " << to_string(s).substr(0, to_string(s).find(" at ")) << '\n'
          << (s.alarm ? fmt::format("  alarm     0x{:02X}\n", s.alarm_code) : "  alarm     none\n");
      if (s.alarm) code = 6;
    }
  } catch (const Error& e) {
    err << "error: " << reword(e.what(), who, cfg.links.front().describe()) << '\n';
    if (const auto h = modbus_hint(e.code()); !h.empty()) err << "hint: " << h << '\n';
    code = exit_code(e.code());
  } catch (const std::exception& e) {
    err << "error: " << e.what() << '\n';
    code = 1;
  }
  spdlog::set_level(level);
  return code;
}

}  // namespace gonio::drivers::probe
