// AlertService — raises, deduplicates, persists, logs and pushes alerts.
//
// The store deduplicates (one open alert per dedup_key); every raise is pushed to the
// `alerts` topic; a new alert (or one whose severity rose) at or above the webhook's
// minimum severity is handed to the webhook sender, which POSTs it with retries. A
// resolution goes the same ways: the alert, now with resolved_at, to the topic (and so to
// MQTT), an `alert.resolved` event to the webhook, a row to the archive's outbox.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "gonio/daemon/rpc/hub.hpp"
#include "gonio/daemon/store/store.hpp"

namespace gonio::daemon {

// Delivers JSON payloads somewhere else (the webhook); implemented with Boost.Beast.
class AlertSink {
 public:
  virtual ~AlertSink() = default;
  virtual void deliver(const nlohmann::json& payload) = 0;
  virtual nlohmann::json stats() const = 0;  // {"delivered", "failed", "pending"}
};

// The resolution of a standing sustained divergence alert by its scan's final verdict
// (docs/decision-rule.md): "resolved: final verdict <decision>: <summary>" when the decision
// no longer supports an alert (agrees, undecided), none when it still does
// (out_of_tolerance, instrument_out_of_spec).
std::optional<std::string> sustained_resolution(std::string_view decision, std::string_view summary);

class AlertService {
 public:
  AlertService(Store& store, Hub& hub, Severity webhook_min = Severity::warning);

  void set_sink(std::shared_ptr<AlertSink> sink);
  std::shared_ptr<AlertSink> sink() const;

  // When the store cannot write (Error(storage_unavailable)), the alert is still logged,
  // published and handed to the webhook, and held in memory (id 0) until flush_held() can
  // store it: an alert about a full disk must not need the disk.
  Alert raise(const AlertDraft& draft);
  // Stores the held alerts (publishing each stored one); stops at the first that cannot be.
  void flush_held();
  std::vector<Alert> held() const;
  Alert ack(std::int64_t id, const std::string& actor);
  // Appends `note` to alert `id`'s message and pushes the alert to subscribers again.
  Alert annotate(std::int64_t id, const std::string& note);
  // Resolves alert `id` (Store::resolve_alert) and, if it stood until now, publishes it and
  // hands the webhook an `alert.resolved` event.
  Alert resolve(std::int64_t id, const std::string& resolution);

 private:
  Store& store_;
  Hub& hub_;
  Severity webhook_min_;
  mutable std::mutex mu_;
  std::shared_ptr<AlertSink> sink_;
  struct Held {
    AlertDraft draft;
    Alert alert;
  };
  std::vector<Held> held_;  // guarded by mu_
  void announce(const Alert& a, bool created, bool escalated);
};

}  // namespace gonio::daemon
