// Strict reading of the Modbus motion driver's JSON configuration (format in
// modbus_motion.hpp): links, timing, per-axis scale, motion profile and map. Soft limits
// and the arms' minimum separation are not driver keys: they live in the instrument's one
// limits table ([instrument.limits], motion/limits.hpp); an old config that still has them
// is refused with an error that says so.
#include <algorithm>
#include <cmath>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/drivers/modbus/modbus_motion.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio::drivers::modbus {
namespace {

using json_util::ObjectReader;
using std::chrono::milliseconds;

LinkConfig read_link(const std::string& name, const nlohmann::json& j, const std::string& ctx) {
  ObjectReader r(j, ctx);
  LinkConfig link;
  link.name = name;
  const auto type = r.required<std::string>("type");
  if (type == "tcp") {
    link.kind = LinkConfig::Kind::tcp;
    link.host = r.required<std::string>("host");
    if (link.host.empty() || link.host.size() > 253)
      throw Error::invalid(r.path("host"), "must be a host name or address");
    link.port = static_cast<int>(r.optional_in<long long>("port", 502, 1, 65535));
  } else if (type == "rtu") {
    link.kind = LinkConfig::Kind::rtu;
    link.device = r.required<std::string>("device");
    if (link.device.empty()) throw Error::invalid(r.path("device"), "must name a serial device");
    link.baud = static_cast<int>(r.optional_in<long long>("baud", 115200, 1200, 4000000));
    parse_serial_format(r.path("format"), r.optional<std::string>("format", "8E1"), link);
    link.rs485 = r.optional<bool>("rs485", false);
  } else {
    throw Error::invalid(r.path("type"), fmt::format("'{}' is not one of rtu, tcp", type));
  }
  r.finish();
  return link;
}

// Keys of older configs whose meaning moved to [instrument.limits].
void reject_moved(ObjectReader& r, const std::string& key, const std::string& instead) {
  if (r.has(key))
    throw Error::invalid(r.path(key),
                         fmt::format("is no longer a Modbus driver key: soft limits now live in "
                                     "[instrument.limits] ({}); move the value there and remove "
                                     "this key",
                                     instead));
}

AxisConfig read_axis(Axis axis, const nlohmann::json& j, const std::string& ctx,
                     const RegisterMap& default_map, const std::vector<LinkConfig>& links) {
  ObjectReader r(j, ctx);
  AxisConfig a;
  a.axis = axis;
  const std::string name(to_text(axis));
  reject_moved(r, "min_deg", fmt::format("{} = [MIN, MAX]", name));
  reject_moved(r, "max_deg", fmt::format("{} = [MIN, MAX]", name));
  if (links.size() == 1 && !r.has("link")) {
    r.raw("link");
    a.link = links.front().name;
  } else {
    a.link = r.required<std::string>("link");
    if (std::none_of(links.begin(), links.end(), [&](const LinkConfig& l) { return l.name == a.link; })) {
      std::string known;
      for (const auto& l : links) known += (known.empty() ? "" : ", ") + l.name;
      throw Error::invalid(r.path("link"), fmt::format("unknown link '{}' (known: {})", a.link, known));
    }
  }
  // Modbus serial line spec §2.2: individual slave addresses are 1..247.
  a.unit = static_cast<int>(r.required_in<long long>("unit", 1, 247));
  a.scale.steps_per_degree = r.required<double>("steps_per_degree");
  if (!(std::abs(a.scale.steps_per_degree) >= 1e-3 && std::abs(a.scale.steps_per_degree) <= 1e7))
    throw Error(Errc::out_of_range,
                fmt::format("{} = {:g} must have a magnitude in [0.001, 1e+07] steps/°",
                            r.path("steps_per_degree"), a.scale.steps_per_degree),
                r.path("steps_per_degree"));
  a.scale.zero_deg = r.optional_in<double>("zero_deg", 0, -3600, 3600, "°");
  a.speed_deg_s = r.optional_in<double>("speed_deg_s", 10, 1e-3, 1e4, "°/s");
  a.accel_deg_s2 = r.optional_in<double>("accel_deg_s2", 50, 1e-3, 1e6, "°/s²");
  a.decel_deg_s2 = r.optional_in<double>("decel_deg_s2", a.accel_deg_s2, 1e-3, 1e6, "°/s²");
  a.current_percent = r.optional_in<double>("current_percent", 100, 0, 100, " %");
  a.in_position_deg = r.optional_in<double>("in_position_deg", 0.01, 0, 10, "°");
  a.following_error_deg = r.optional_in<double>("following_error_deg", 0.5, 0, 360, "°");
  if (const auto* m = r.raw("register_map"))
    a.map = RegisterMap::from_json(*m, r.path("register_map"));
  else
    a.map = default_map;
  r.finish();
  // Device ranges of the derived step values (int32 registers).
  const double hz = a.scale.to_step_rate(a.speed_deg_s);
  if (hz < 1 || hz > 2147483647.0)
    throw Error(Errc::out_of_range,
                fmt::format("{}: speed {:g}°/s is {:g} steps/s, outside [1, 2147483647]",
                            ctx, a.speed_deg_s, hz),
                join_field(ctx, "speed_deg_s"));
  for (const auto& [key, v] : {std::pair{"accel_deg_s2", a.accel_deg_s2},
                               std::pair{"decel_deg_s2", a.decel_deg_s2}}) {
    const double counts = a.scale.to_step_rate(v) / a.map.rate_unit_hz_per_s;
    if (counts < 1 || counts > 2147483647.0)
      throw Error(Errc::out_of_range,
                  fmt::format("{}: {} {:g}°/s² is {:g} rate counts, outside [1, 2147483647]",
                              ctx, key, v, counts),
                  join_field(ctx, key));
  }
  return a;
}

}  // namespace

void parse_serial_format(const std::string& field, const std::string& format, LinkConfig& out) {
  // Data bits 5..8, parity N/E/O, stop bits 1..2 (libmodbus modbus_new_rtu).
  if (format.size() != 3 || format[0] < '5' || format[0] > '8' ||
      std::string_view("NEO").find(static_cast<char>(std::toupper(static_cast<unsigned char>(format[1])))) ==
          std::string_view::npos ||
      (format[2] != '1' && format[2] != '2'))
    throw Error::invalid(field, fmt::format("'{}' is not a serial format like 8E1 (data bits "
                                            "5-8, parity N/E/O, stop bits 1-2)",
                                            format));
  out.data_bits = format[0] - '0';
  out.parity = static_cast<char>(std::toupper(static_cast<unsigned char>(format[1])));
  out.stop_bits = format[2] - '0';
}

MotionConfig MotionConfig::from_json(const nlohmann::json& j) {
  ObjectReader r(j, "");
  MotionConfig c;
  reject_moved(r, "min_separation_deg", "min_separation");
  const auto* links = r.raw("links");
  if (links == nullptr) throw Error::invalid("links", "is required");
  if (!links->is_object() || links->empty())
    throw Error::invalid("links", "expected an object with at least one named link");
  for (const auto& [name, lj] : links->items())
    c.links.push_back(read_link(name, lj, join_field("links", name)));

  RegisterMap default_map;
  if (const auto* m = r.raw("register_map")) default_map = RegisterMap::from_json(*m, "register_map");

  c.timing.response_timeout = milliseconds(r.optional_in<long long>("response_timeout_ms", 200, 1, 60000));
  c.timing.byte_timeout = milliseconds(r.optional_in<long long>("byte_timeout_ms", 50, 1, 10000));
  c.timing.retries = static_cast<int>(r.optional_in<long long>("retries", 2, 0, 10));
  if (const auto* rc = r.raw("reconnect")) {
    ObjectReader rr(*rc, "reconnect");
    c.timing.backoff_initial = milliseconds(rr.optional_in<long long>("initial_ms", 50, 1, 60000));
    c.timing.backoff_max = milliseconds(rr.optional_in<long long>("max_ms", 2000, 1, 600000));
    if (c.timing.backoff_max < c.timing.backoff_initial)
      throw Error::invalid(rr.path("max_ms"), "must not be below initial_ms");
    rr.finish();
  }
  c.poll_interval = milliseconds(r.optional_in<long long>("poll_interval_ms", 10, 1, 1000));
  c.settle_timeout = milliseconds(r.optional_in<long long>("settle_timeout_ms", 1000, 0, 60000));

  const auto* axes = r.raw("axes");
  if (axes == nullptr) throw Error::invalid("axes", "is required");
  if (!axes->is_object() || axes->empty())
    throw Error::invalid("axes", "expected an object with at least one axis");
  std::set<std::pair<std::string, int>> units;
  for (const auto& [name, aj] : axes->items()) {
    const Axis axis = parse_enum<Axis>(name, join_field("axes", name));
    auto a = read_axis(axis, aj, join_field("axes", name), default_map, c.links);
    if (!units.emplace(a.link, a.unit).second)
      throw Error::invalid(join_field(join_field("axes", name), "unit"),
                           fmt::format("unit {} on link '{}' is already used by another axis",
                                       a.unit, a.link));
    c.axes.push_back(std::move(a));
  }
  // Fixed order: incidence, receive, rotation, tilt.
  std::sort(c.axes.begin(), c.axes.end(),
            [](const AxisConfig& a, const AxisConfig& b) { return a.axis < b.axis; });
  r.finish();
  return c;
}

}  // namespace gonio::drivers::modbus
