// The Modbus motion driver: MotionController over libmodbus, RTU or TCP, one Modbus unit
// id per axis, register map from config (preset `az`, see register_map.hpp).
//
// Configuration (JSON; unknown keys rejected, every number range-checked):
//   {
//     "links": {                                   // one or more
//       "bus": {"type": "rtu", "device": "/dev/ttyUSB0", "baud": 115200, "format": "8E1",
//               "rs485": false},
//       "net": {"type": "tcp", "host": "192.168.0.10", "port": 502}
//     },
//     "register_map": {"preset": "az"},            // default for every axis
//     "response_timeout_ms": 200, "byte_timeout_ms": 50, "retries": 2,
//     "reconnect": {"initial_ms": 50, "max_ms": 2000},
//     "poll_interval_ms": 10,                      // status polling while waiting
//     "settle_timeout_ms": 1000,                   // profile done -> IN-POS, else following error
//     "axes": {
//       "incidence": {"link": "bus", "unit": 1, "steps_per_degree": 1000, "zero_deg": 0,
//                     "speed_deg_s": 10, "accel_deg_s2": 50, "decel_deg_s2": 50,
//                     "current_percent": 100, "in_position_deg": 0.01, "following_error_deg": 0.5,
//                     "register_map": {...}},      // optional per-axis override
//       "receive": {...}, "rotation": {...}, "tilt": {...}
//     }
//   }
// "link" may be omitted when there is exactly one link.
//
// Soft limits and the arms' minimum separation are not driver keys: the instrument's one
// limits table ([instrument.limits], motion/limits.hpp) holds them and GuardedMotion
// enforces them around this driver. The old keys (axes.*.min_deg, axes.*.max_deg,
// min_separation_deg) are refused with Error(invalid_argument) saying so.
#pragma once

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "gonio/drivers/modbus/link.hpp"
#include "gonio/drivers/modbus/register_map.hpp"
#include "gonio/drivers/motion/motion_controller.hpp"

namespace gonio::drivers {

namespace modbus {

struct AxisConfig {
  Axis axis = Axis::incidence;
  std::string link;
  int unit = 1;  // 1..247
  AxisScale scale;
  double speed_deg_s = 10;
  double accel_deg_s2 = 50;
  double decel_deg_s2 = 50;
  double current_percent = 100;
  double in_position_deg = 0.01;      // accepted distance of the feedback from the target
  double following_error_deg = 0.5;   // largest feedback-vs-command distance
  RegisterMap map;
};

struct MotionConfig {
  std::vector<LinkConfig> links;
  std::vector<AxisConfig> axes;
  LinkTiming timing;
  std::chrono::milliseconds poll_interval{10};
  std::chrono::milliseconds settle_timeout{1000};

  static MotionConfig from_json(const nlohmann::json& j);
};

// Parses "8E1"-style serial formats into data bits, parity and stop bits.
void parse_serial_format(const std::string& field, const std::string& format, LinkConfig& out);

}  // namespace modbus

std::unique_ptr<MotionController> make_modbus_motion(const modbus::MotionConfig& config);
std::unique_ptr<MotionController> make_modbus_motion(const nlohmann::json& config);

}  // namespace gonio::drivers
