// ModbusSimConfig::from_json: strict reading of the Modbus simulator's JSON configuration
// (format in modbus_sim.hpp), every number range-checked, errors naming the key.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"
#include "gonio/sim/devsim/modbus_sim.hpp"

namespace gonio::drivers::devsim {
namespace {

using json_util::ObjectReader;
using modbus::RegisterMap;

std::optional<SimFault> read_fault(ObjectReader& parent, const std::string& key, bool alarm) {
  const auto* j = parent.raw(key);
  if (j == nullptr) return std::nullopt;
  ObjectReader r(*j, parent.path(key));
  SimFault f;
  f.move = static_cast<int>(r.required_in<long long>("move", 1, 1000000));
  f.fraction = r.optional_in("fraction", 0.5, 0.0, 1.0);
  if (alarm) f.code = static_cast<std::uint32_t>(r.optional_in<long long>("code", 0x30, 1, 0xFFFF));
  r.finish();
  return f;
}

}  // namespace

ModbusSimConfig ModbusSimConfig::from_json(const nlohmann::json& j) {
  ObjectReader r(j, "");
  ModbusSimConfig c;
  if (const auto* t = r.raw("tcp")) {
    ObjectReader tr(*t, "tcp");
    c.tcp_host = tr.optional<std::string>("host", "127.0.0.1");
    c.tcp_port = static_cast<int>(tr.optional_in<long long>("port", 0, 0, 65535));
    tr.finish();
  }
  c.rtu = r.optional<bool>("rtu", false);
  const auto motion = r.optional<std::string>("motion", "profile");
  if (motion != "profile" && motion != "instant")
    throw Error::invalid("motion", fmt::format("'{}' is not one of profile, instant", motion));
  c.instant = motion == "instant";
  if (const auto* m = r.raw("register_map")) c.map = RegisterMap::from_json(*m, "register_map");
  c.record_path = r.optional<std::string>("record", "");
  const auto* units = r.raw("units");
  if (units == nullptr || !units->is_array() || units->empty())
    throw Error::invalid("units", "expected a non-empty array of simulated axes");
  for (std::size_t i = 0; i < units->size(); ++i) {
    const std::string ctx = fmt::format("units[{}]", i);
    ObjectReader ur((*units)[i], ctx);
    SimAxisConfig a;
    a.unit = static_cast<int>(ur.required_in<long long>("unit", 1, 247));
    for (const auto& other : c.units)
      if (other.unit == a.unit)
        throw Error::invalid(ur.path("unit"), fmt::format("unit {} appears twice", a.unit));
    a.position_steps = static_cast<std::int32_t>(ur.optional_in<double>("position_steps", 0, -2147483647.0, 2147483647.0));
    a.in_position_band_steps = ur.optional_in<double>("in_position_band_steps", 2, 0, 1e6);
    a.home_position_steps = static_cast<std::int32_t>(ur.optional_in<double>("home_position_steps", 0, -2147483647.0, 2147483647.0));
    a.home_speed_hz = ur.optional_in<double>("home_speed_hz", 20000, 1, 1e7);
    a.home_accel_hz_s = ur.optional_in<double>("home_accel_hz_s", 200000, 1, 1e9);
    a.alarm_at_move = read_fault(ur, "alarm_at_move", true);
    a.stall_at_move = read_fault(ur, "stall_at_move", false);
    ur.finish();
    c.units.push_back(a);
  }
  r.finish();
  if (!c.tcp_host && !c.rtu) throw Error::invalid("tcp", "the simulator needs tcp, rtu or both");
  return c;
}

}  // namespace gonio::drivers::devsim
