// Alerts: persistence with dedup, log, subscribers, webhook (see alerts.hpp).
#include "gonio/daemon/alerts.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace gonio::daemon {

AlertService::AlertService(Store& store, Hub& hub, Severity webhook_min)
    : store_(store), hub_(hub), webhook_min_(webhook_min) {}

void AlertService::set_sink(std::shared_ptr<AlertSink> sink) {
  std::lock_guard lock(mu_);
  sink_ = std::move(sink);
}

std::shared_ptr<AlertSink> AlertService::sink() const {
  std::lock_guard lock(mu_);
  return sink_;
}

Alert AlertService::raise(const AlertDraft& draft) {
  bool created = false;
  // Severity before the raise, to notice an escalation of an open alert.
  std::optional<Severity> old_severity;
  AlertFilter open;
  open.acknowledged = false;
  open.scan_id = draft.scan_id;
  open.limit = 1000;
  for (const auto& a : store_.alerts(open))
    if (a.dedup_key == draft.dedup_key) old_severity = a.severity;
  const Alert a = store_.raise_alert(draft, &created);
  const auto level = a.severity == Severity::critical  ? spdlog::level::err
                     : a.severity == Severity::warning ? spdlog::level::warn
                                                       : spdlog::level::info;
  if (created || a.count <= 1 || (a.count % 50) == 0)
    spdlog::log(level, "alert {} [{}] {}: {}{}", a.id, to_text(a.severity), a.kind, a.message,
                a.count > 1 ? fmt::format(" (×{})", a.count) : std::string());
  hub_.publish(Topic::alerts, "alert", nlohmann::json(a), a.scan_id);
  const bool escalated = old_severity && a.severity > *old_severity;
  if ((created || escalated) && a.severity >= webhook_min_) {
    if (auto s = sink())
      s->deliver(nlohmann::json{{"event", created ? "alert.raised" : "alert.escalated"},
                                {"alert", a}});
  }
  return a;
}

Alert AlertService::ack(std::int64_t id, const std::string& actor) {
  const Alert a = store_.ack_alert(id, actor);
  spdlog::info("alert {} acknowledged by {}", id, actor);
  hub_.publish(Topic::alerts, "alert", nlohmann::json(a), a.scan_id);
  return a;
}

Alert AlertService::annotate(std::int64_t id, const std::string& note) {
  const auto old = store_.alert(id);
  if (!old) throw Error::not_found("alert", fmt::format("alert {}", id));
  const Alert a = store_.set_alert_message(id, fmt::format("{}; {}", old->message, note));
  spdlog::info("alert {}: {}", id, note);
  hub_.publish(Topic::alerts, "alert", nlohmann::json(a), a.scan_id);
  return a;
}

}  // namespace gonio::daemon
