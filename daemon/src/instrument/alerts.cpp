// Alerts: persistence with dedup, log, subscribers, webhook (see alerts.hpp).
#include "gonio/daemon/instrument/alerts.hpp"

#include <algorithm>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace gonio::daemon {

std::optional<std::string> sustained_resolution(std::string_view decision, std::string_view summary) {
  if (decision == "out_of_tolerance" || decision == "instrument_out_of_spec") return std::nullopt;
  return fmt::format("resolved: final verdict {}: {}", decision, summary);
}

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
  if (store_.writable()) flush_held();
  bool created = false;
  // Severity before the raise, to notice an escalation of an open alert.
  std::optional<Severity> old_severity;
  AlertFilter open;
  open.acknowledged = false;
  open.scan_id = draft.scan_id;
  open.limit = 1000;
  for (const auto& a : store_.alerts(open))
    if (a.dedup_key == draft.dedup_key) old_severity = a.severity;
  Alert a;
  try {
    a = store_.raise_alert(draft, &created);
  } catch (const Error& e) {
    if (e.code() != Errc::storage_unavailable) throw;
    // Held in memory, deduplicated like the store would, published all the same.
    std::lock_guard lock(mu_);
    const auto it = std::find_if(held_.begin(), held_.end(),
                                 [&](const Held& h) { return h.draft.dedup_key == draft.dedup_key; });
    const auto now = utc::now();
    if (it == held_.end()) {
      a.kind = draft.kind;
      a.severity = draft.severity;
      a.dedup_key = draft.dedup_key;
      a.scan_id = draft.scan_id;
      a.sample_id = draft.sample_id;
      a.point_index = draft.point_index;
      a.message = draft.message;
      a.first_at = a.last_at = now;
      held_.push_back(Held{draft, a});
      created = !old_severity;
    } else {
      it->draft = draft;
      it->alert.severity = std::max(it->alert.severity, draft.severity);
      it->alert.message = draft.message;
      it->alert.point_index = draft.point_index;
      it->alert.last_at = now;
      ++it->alert.count;
      a = it->alert;
    }
  }
  announce(a, created, old_severity && a.severity > *old_severity);
  return a;
}

void AlertService::flush_held() {
  for (;;) {
    Held h;
    {
      std::lock_guard lock(mu_);
      if (held_.empty()) return;
      h = held_.front();
    }
    bool created = false;
    Alert a;
    try {
      AlertDraft d = h.draft;
      d.severity = h.alert.severity;
      a = store_.raise_alert(d, &created);
    } catch (const Error& e) {
      if (e.code() != Errc::storage_unavailable) throw;
      return;
    }
    {
      std::lock_guard lock(mu_);
      if (!held_.empty() && held_.front().draft.dedup_key == h.draft.dedup_key) held_.erase(held_.begin());
    }
    spdlog::info("alert {} stored now that the store can write: {}", a.id, a.message);
    hub_.publish(Topic::alerts, "alert", nlohmann::json(a), a.scan_id);
  }
}

std::vector<Alert> AlertService::held() const {
  std::lock_guard lock(mu_);
  std::vector<Alert> out;
  for (const auto& h : held_) out.push_back(h.alert);
  return out;
}

void AlertService::announce(const Alert& a, bool created, bool escalated) {
  const auto level = a.severity == Severity::critical  ? spdlog::level::err
                     : a.severity == Severity::warning ? spdlog::level::warn
                                                       : spdlog::level::info;
  if (created || a.count <= 1 || (a.count % 50) == 0)
    spdlog::log(level, "alert {} [{}] {}: {}{}", a.id, to_text(a.severity), a.kind, a.message,
                a.count > 1 ? fmt::format(" (×{})", a.count) : std::string());
  hub_.publish(Topic::alerts, "alert", nlohmann::json(a), a.scan_id);
  if ((created || escalated) && a.severity >= webhook_min_) {
    if (auto s = sink())
      s->deliver(nlohmann::json{{"event", created ? "alert.raised" : "alert.escalated"},
                                {"alert", a}});
  }
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

Alert AlertService::resolve(std::int64_t id, const std::string& resolution) {
  bool changed = false;
  const Alert a = store_.resolve_alert(id, resolution, &changed);
  if (!changed) return a;
  spdlog::info("alert {} resolved: {}", id, resolution);
  hub_.publish(Topic::alerts, "alert", nlohmann::json(a), a.scan_id);
  if (a.severity >= webhook_min_)
    if (auto s = sink()) s->deliver(nlohmann::json{{"event", "alert.resolved"}, {"alert", a}});
  return a;
}

}  // namespace gonio::daemon
