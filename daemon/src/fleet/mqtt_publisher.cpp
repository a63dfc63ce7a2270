// The MQTT publisher: libmosquitto's network thread, a sender thread and a bounded queue
// (see mqtt.hpp).
#include <mosquitto.h>

#include <algorithm>
#include <cstring>
#include <mutex>
#include <vector>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/fleet/mqtt.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {

using nlohmann::json;
using namespace std::chrono_literals;

namespace {

constexpr std::size_t kMaxRetainedScans = 64;
// Messages handed to libmosquitto and not yet acknowledged, at most: libmosquitto queues
// without a bound of its own, so the bound on memory is ours.
constexpr std::size_t kMaxOutstanding = 256;

void lib_init() {
  static std::once_flag once;
  std::call_once(once, [] { mosquitto_lib_init(); });
}

}  // namespace

MqttPublisher::MqttPublisher(const Config::Mqtt& config, std::string instrument,
                             std::function<std::string()> current_state)
    : config_(config), current_state_(std::move(current_state)) {
  topics_.prefix = config_.topic_prefix;
  topics_.instrument = std::move(instrument);
  lib_init();
  const auto client_id = "goniod-" + topics_.instrument;
  mosq_ = mosquitto_new(client_id.c_str(), true, this);
  if (!mosq_) throw Error(Errc::io_error, "mqtt: cannot create the client");
  mosquitto_int_option(mosq_, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V311);
  mosquitto_connect_callback_set(mosq_, [](mosquitto*, void* self, int rc) {
    static_cast<MqttPublisher*>(self)->on_connect(rc);
  });
  mosquitto_disconnect_callback_set(mosq_, [](mosquitto*, void* self, int rc) {
    static_cast<MqttPublisher*>(self)->on_disconnect(rc);
  });
  mosquitto_publish_callback_set(mosq_, [](mosquitto*, void* self, int) {
    static_cast<MqttPublisher*>(self)->on_publish();
  });
  const auto offline = std::string(kMqttOffline);
  const auto fail = [&](std::string_view what, int rc) {
    mosquitto_destroy(mosq_);
    mosq_ = nullptr;
    throw Error(Errc::invalid_argument, fmt::format("mqtt: {}: {}", what, mosquitto_strerror(rc)));
  };
  if (int rc = mosquitto_will_set(mosq_, topics_.state().c_str(), static_cast<int>(offline.size()),
                                  offline.data(), config_.qos, true);
      rc != MOSQ_ERR_SUCCESS)
    fail("last will", rc);
  if (!config_.username.empty())
    if (int rc = mosquitto_username_pw_set(mosq_, config_.username.c_str(),
                                           config_.password.empty() ? nullptr : config_.password.c_str());
        rc != MOSQ_ERR_SUCCESS)
      fail("credentials", rc);
  const auto url = MqttUrl::parse(config_.url);
  if (url.tls) {
    const char* ca = config_.ca_file.empty() ? nullptr : config_.ca_file.c_str();
    const char* capath = ca ? nullptr : "/etc/ssl/certs";  // the system's CAs
    if (int rc = mosquitto_tls_set(mosq_, ca, capath,
                                   config_.cert_file.empty() ? nullptr : config_.cert_file.c_str(),
                                   config_.key_file.empty() ? nullptr : config_.key_file.c_str(), nullptr);
        rc != MOSQ_ERR_SUCCESS)
      fail("mqtt.ca_file/cert_file/key_file", rc);
  }
  mosquitto_reconnect_delay_set(mosq_, 1, 10, true);
}

MqttPublisher::~MqttPublisher() {
  stop();
  if (mosq_) mosquitto_destroy(mosq_);
}

void MqttPublisher::start() {
  const auto url = MqttUrl::parse(config_.url);
  // Asynchronous: a broker that is down now is connected to by libmosquitto's thread later.
  if (int rc = mosquitto_connect_async(mosq_, url.host.c_str(), url.port, config_.keepalive_s);
      rc != MOSQ_ERR_SUCCESS) {
    std::lock_guard lock(mu_);
    last_error_ = rc == MOSQ_ERR_ERRNO ? std::string(std::strerror(errno)) : mosquitto_strerror(rc);
    spdlog::warn("mqtt: {}: {}; retrying in the background", config_.url, last_error_);
  }
  if (int rc = mosquitto_loop_start(mosq_); rc != MOSQ_ERR_SUCCESS)
    throw Error(Errc::io_error, fmt::format("mqtt: cannot start the network thread: {}",
                                            mosquitto_strerror(rc)));
  thread_ = std::thread([this] { run(); });
}

void MqttPublisher::stop() {
  {
    std::lock_guard lock(mu_);
    if (stopping_ || !thread_.joinable()) {
      stopping_ = true;
      return;
    }
    stopping_ = true;
  }
  cv_.notify_all();
  thread_.join();
  bool connected = false;
  {
    std::lock_guard lock(mu_);
    connected = connected_;
  }
  if (connected) {
    // Say so before going: a clean stop is not a lost instrument, but it is offline.
    const auto offline = std::string(kMqttOffline);
    {
      std::lock_guard lock(mu_);
      ++outstanding_;
    }
    mosquitto_publish(mosq_, nullptr, topics_.state().c_str(), static_cast<int>(offline.size()),
                      offline.data(), config_.qos, true);
    std::unique_lock lock(mu_);
    cv_.wait_for(lock, 2s, [&] { return outstanding_ == 0 || !connected_; });
  }
  mosquitto_disconnect(mosq_);
  mosquitto_loop_stop(mosq_, true);
}

void MqttPublisher::on_connect(int rc) {
  std::lock_guard lock(mu_);
  if (rc != 0) {
    last_error_ = mosquitto_connack_string(rc);
    return;
  }
  connected_ = true;
  ++connects_;
  outstanding_ = 0;  // a clean session: what was in flight is resent or gone
  refresh_state_ = true;
  for (auto& [topic, r] : retained_) r.dirty = true;
  last_error_.clear();
  cv_.notify_all();
}

void MqttPublisher::on_disconnect(int rc) {
  std::lock_guard lock(mu_);
  connected_ = false;
  if (rc != 0) last_error_ = "connection lost";
  cv_.notify_all();
}

void MqttPublisher::on_publish() {
  std::lock_guard lock(mu_);
  if (outstanding_ > 0) --outstanding_;
  cv_.notify_all();
}

void MqttPublisher::publish(std::string_view method, const std::string& params_json,
                            std::optional<std::int64_t> scan) {
  auto m = mqtt_route(topics_, method, params_json, scan);
  if (!m) return;
  std::lock_guard lock(mu_);
  if (stopping_) return;
  if (m->retain) {
    if (m->topic.starts_with(topics_.base() + "/scan/")) {
      // Remember the scan (most recent first) and forget the oldest beyond the bound.
      const auto id = scan.value_or(0);
      if (std::find(retained_scans_.begin(), retained_scans_.end(), id) == retained_scans_.end()) {
        retained_scans_.push_front(id);
        if (retained_scans_.size() > kMaxRetainedScans) {
          const auto old = retained_scans_.back();
          retained_scans_.pop_back();
          retained_.erase(topics_.scan(old));
          retained_.erase(topics_.progress(old));
        }
      }
    }
    auto& r = retained_[m->topic];
    r.payload = std::move(m->payload);
    r.dirty = true;
  } else {
    if (queue_.size() >= config_.queue) {
      queue_.pop_front();  // the freshest telemetry is worth more than the oldest
      ++dropped_;
    }
    queue_.push_back(std::move(*m));
  }
  cv_.notify_all();
}

void MqttPublisher::run() {
  std::unique_lock lock(mu_);
  for (;;) {
    cv_.wait(lock, [&] {
      if (stopping_) return true;
      if (!connected_ || outstanding_ >= kMaxOutstanding) return false;
      if (refresh_state_ || !queue_.empty()) return true;
      for (const auto& [t, r] : retained_)
        if (r.dirty) return true;
      return false;
    });
    if (stopping_) return;
    if (refresh_state_ && current_state_) {
      refresh_state_ = false;
      lock.unlock();
      auto state = current_state_();  // instrument.status takes the instrument's lock
      lock.lock();
      auto& r = retained_[topics_.state()];
      r.payload = std::move(state);
      r.dirty = true;
    }
    refresh_state_ = false;
    // Retained topics first (state before the telemetry that follows it), then the queue.
    std::vector<MqttMessage> batch;
    for (auto& [topic, r] : retained_)
      if (r.dirty && batch.size() + outstanding_ < kMaxOutstanding) {
        batch.push_back({topic, r.payload, true});
        r.dirty = false;
      }
    while (!queue_.empty() && batch.size() + outstanding_ < kMaxOutstanding) {
      batch.push_back(std::move(queue_.front()));
      queue_.pop_front();
    }
    outstanding_ += batch.size();
    lock.unlock();
    std::vector<const MqttMessage*> failed;
    for (const auto& m : batch) {
      const int rc = mosquitto_publish(mosq_, nullptr, m.topic.c_str(),
                                       static_cast<int>(m.payload.size()), m.payload.data(),
                                       config_.qos, m.retain);
      if (rc != MOSQ_ERR_SUCCESS) failed.push_back(&m);
    }
    lock.lock();
    published_ += batch.size() - failed.size();
    // The connection went in the meantime: retained topics go again after the reconnect;
    // telemetry that did not make it is counted as dropped.
    outstanding_ -= std::min(outstanding_, failed.size());
    for (const auto* m : failed) {
      if (!m->retain) {
        ++dropped_;
      } else if (auto it = retained_.find(m->topic); it != retained_.end()) {
        it->second.dirty = true;
      }
    }
  }
}

json MqttPublisher::status() const {
  std::lock_guard lock(mu_);
  return json{{"url", config_.url},
              {"instrument", topics_.instrument},
              {"topic", topics_.base()},
              {"connected", connected_},
              {"queued", queue_.size()},
              {"published", published_},
              {"dropped", dropped_},
              {"connects", connects_},
              {"last_error", last_error_}};
}

}  // namespace gonio::daemon
