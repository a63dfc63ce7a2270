// Hub notifications → MQTT topics (see mqtt.hpp).
#include "gonio/daemon/fleet/mqtt.hpp"

namespace gonio::daemon {

std::optional<MqttMessage> mqtt_route(const MqttTopics& topics, std::string_view method,
                                      const std::string& params_json,
                                      std::optional<std::int64_t> scan) {
  if (method == "instrument.state") return MqttMessage{topics.state(), params_json, true};
  if (method == "alert") return MqttMessage{topics.alert(), params_json, false};
  if (method != "scan.state" && method != "scan.progress" && method != "scan.point")
    return std::nullopt;
  if (!scan) {
    // Every scan notification names its scan as "scan" (scan.point: "scan_id").
    const auto j = nlohmann::json::parse(params_json, nullptr, false);
    const char* key = method == "scan.point" ? "scan_id" : "scan";
    if (!j.is_object() || !j.contains(key) || !j[key].is_number_integer()) return std::nullopt;
    scan = j[key].get<std::int64_t>();
  }
  if (method == "scan.state") return MqttMessage{topics.scan(*scan), params_json, true};
  if (method == "scan.progress") return MqttMessage{topics.progress(*scan), params_json, true};
  return MqttMessage{topics.point(*scan), params_json, false};
}

}  // namespace gonio::daemon
