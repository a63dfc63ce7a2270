// MQTT telemetry (docs/architecture.md §11): every hub notification, mirrored to a broker.
//
//   <prefix>/<instrument>/state                 instrument.state   retained; will: offline
//   <prefix>/<instrument>/scan/<id>             scan.state         retained
//   <prefix>/<instrument>/scan/<id>/progress    scan.progress      retained
//   <prefix>/<instrument>/scan/<id>/point       scan.point         every committed point
//   <prefix>/<instrument>/alert                 alert              raised, bumped, acknowledged
//
// Payloads are the params of the JSON-RPC notification named beside the topic. Publishing
// never waits for the broker: publish() puts the message in a bounded queue that a thread
// of its own empties while the broker is reachable. When the queue is full the oldest
// message is dropped and counted (the archive, not MQTT, is the lossless path). Retained
// topics are kept as their last payload rather than queued, so they are never dropped and
// are published again after every reconnect: a broker that restarted without persistence
// is current again as soon as goniod is back on it.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <list>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>

#include <nlohmann/json.hpp>

#include "gonio/daemon/config/config.hpp"

struct mosquitto;

namespace gonio::daemon {

struct MqttTopics {
  std::string prefix = "gonio";
  std::string instrument;

  std::string base() const { return prefix + "/" + instrument; }
  std::string state() const { return base() + "/state"; }
  std::string scan(std::int64_t id) const { return base() + "/scan/" + std::to_string(id); }
  std::string progress(std::int64_t id) const { return scan(id) + "/progress"; }
  std::string point(std::int64_t id) const { return scan(id) + "/point"; }
  std::string alert() const { return base() + "/alert"; }
};

// The payload of the state topic's last will, and of a clean stop.
inline constexpr std::string_view kMqttOffline = R"({"state":"offline"})";

struct MqttMessage {
  std::string topic;
  std::string payload;
  bool retain = false;
};

// The message for a hub notification, nullopt for notifications MQTT does not carry. `scan`
// is the scan the notification is about, when the hub was told.
std::optional<MqttMessage> mqtt_route(const MqttTopics& topics, std::string_view method,
                                      const std::string& params_json,
                                      std::optional<std::int64_t> scan);

class MqttPublisher {
 public:
  // `current_state` gives the instrument.state params, published on every connect.
  MqttPublisher(const Config::Mqtt& config, std::string instrument,
                std::function<std::string()> current_state);
  ~MqttPublisher();
  MqttPublisher(const MqttPublisher&) = delete;
  MqttPublisher& operator=(const MqttPublisher&) = delete;

  // Connects in the background (a broker that is down is retried, never waited for).
  void start();
  // Publishes `offline` on the state topic when connected, then disconnects.
  void stop();

  // The hub's tap: never blocks on the broker.
  void publish(std::string_view method, const std::string& params_json,
               std::optional<std::int64_t> scan);

  // {url, instrument, connected, queued, published, dropped, connects, last_error}
  nlohmann::json status() const;
  const MqttTopics& topics() const noexcept { return topics_; }

 private:
  void run();
  void on_connect(int rc);
  void on_disconnect(int rc);
  void on_publish();

  Config::Mqtt config_;
  MqttTopics topics_;
  std::function<std::string()> current_state_;
  mosquitto* mosq_ = nullptr;

  mutable std::mutex mu_;
  std::condition_variable cv_;
  bool stopping_ = false, connected_ = false, refresh_state_ = false;
  std::deque<MqttMessage> queue_;
  // Retained topics: last payload and whether the broker still lacks it. Scan topics are
  // kept for the most recent kMaxRetainedScans scans (what a reconnect publishes again).
  struct Retained {
    std::string payload;
    bool dirty = true;
  };
  std::map<std::string, Retained> retained_;
  std::list<std::int64_t> retained_scans_;
  std::size_t outstanding_ = 0;  // handed to libmosquitto, not yet acknowledged
  std::uint64_t published_ = 0, dropped_ = 0, connects_ = 0;
  std::string last_error_;
  std::thread thread_;
};

}  // namespace gonio::daemon
