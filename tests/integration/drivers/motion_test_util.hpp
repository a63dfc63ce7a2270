// Shared set-up of the Modbus motion integration tests: simulator and driver configs with
// fast timing, error capture and bounded waiting.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "gonio/drivers/modbus/modbus_motion.hpp"
#include "gonio/drivers/motion/guarded_motion.hpp"
#include "gonio/drivers/motion/limits.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/test/error_of.hpp"

namespace motion_test {

using nlohmann::json;
using namespace std::chrono_literals;

inline constexpr double kStepsPerDegree = 100;

// Two simulated axes: unit 1 (incidence, at 0°) and unit 2 (receive, at 30°: the arms
// start clear of each other).
inline json sim_config(bool tcp, bool rtu, json unit1_extra = json::object(),
                       json unit2_extra = json::object()) {
  json u1{{"unit", 1}};
  json u2{{"unit", 2}, {"position_steps", 30 * kStepsPerDegree}};
  u1.update(unit1_extra);
  u2.update(unit2_extra);
  json j{{"rtu", rtu}, {"units", json::array({u1, u2})}};
  if (tcp) j["tcp"] = {{"host", "127.0.0.1"}, {"port", 0}};
  return j;
}

inline json axis(int unit, json extra = json::object()) {
  json a{{"unit", unit},
         {"steps_per_degree", kStepsPerDegree},
         {"speed_deg_s", 200},
         {"accel_deg_s2", 4000},
         {"in_position_deg", 0.02},
         {"following_error_deg", 2}};
  a.update(extra);
  return a;
}

inline json driver_config(json link) {
  return json{{"links", {{"main", link}}},
              {"response_timeout_ms", 100},
              {"byte_timeout_ms", 20},
              {"retries", 1},
              {"reconnect", {{"initial_ms", 20}, {"max_ms", 200}}},
              {"poll_interval_ms", 5},
              {"settle_timeout_ms", 300},
              {"axes", {{"incidence", axis(1)}, {"receive", axis(2)}}}};
}

// The Modbus driver for `config` as an instrument uses it: inside the GuardedMotion of a
// limits table with both arms within ±90° and at least `min_separation` apart.
inline std::unique_ptr<gonio::drivers::MotionController> guarded_motion(const json& config,
                                                                        double min_separation = 10) {
  gonio::drivers::MotionLimits limits;
  limits.incidence_min = limits.receive_min = -90;
  limits.incidence_max = limits.receive_max = 90;
  limits.min_separation = min_separation;
  return std::make_unique<gonio::drivers::GuardedMotion>(
      gonio::drivers::make_modbus_motion(config), limits.guard(min_separation));
}

inline json tcp_link(int port) {
  return json{{"type", "tcp"}, {"host", "127.0.0.1"}, {"port", port}};
}

inline json rtu_link(const std::string& device) {
  return json{{"type", "rtu"}, {"device", device}, {"baud", 115200}, {"format", "8E1"}};
}

using gonio::test::error_of;

inline bool mentions(const gonio::Error& e, const std::string& s) {
  return std::string(e.what()).find(s) != std::string::npos;
}

// Polls `pred` every 2 ms, at most `limit`; returns its last value.
inline bool wait_until(const std::function<bool()>& pred, std::chrono::milliseconds limit = 5s) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < end) {
    if (pred()) return true;
    std::this_thread::sleep_for(2ms);
  }
  return pred();
}

}  // namespace motion_test
