// Store — alerts, deduplicated on their key while unacknowledged (store.hpp).
#include <algorithm>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "store/sqlite.hpp"

namespace gonio::daemon {

using nlohmann::json;

namespace {

constexpr const char* kAlertColumns =
    "id, kind, severity, dedup_key, scan_id, sample_id, point_index, message, first_at, "
    "last_at, count, acknowledged, acknowledged_by, acknowledged_at, resolved_at, resolution";

Alert read_alert(const db::Stmt& s) {
  Alert a;
  a.id = s.i64(0);
  a.kind = s.text(1);
  a.severity = static_cast<Severity>(std::clamp<std::int64_t>(s.i64(2), 0, 2));
  a.dedup_key = s.text(3);
  a.scan_id = s.opt_i64(4);
  a.sample_id = s.opt_i64(5);
  a.point_index = s.opt_i64(6);
  a.message = s.text(7);
  a.first_at = s.text(8);
  a.last_at = s.text(9);
  a.count = s.i64(10);
  a.acknowledged = s.i64(11) != 0;
  a.acknowledged_by = s.text(12);
  a.acknowledged_at = s.opt_text(13);
  a.resolved_at = s.opt_text(14);
  a.resolution = s.opt_text(15);
  return a;
}

std::optional<Alert> alert_by_id(db::Connection& c, std::int64_t id) {
  return db::query_one(c, fmt::format("SELECT {} FROM alerts WHERE id = ?", kAlertColumns),
                       read_alert, id);
}

}  // namespace

Alert Store::raise_alert(const AlertDraft& d, bool* created) {
  std::lock_guard lock(write_mu_);
  db::Transaction t(*writer_);
  const auto now = utc::now();
  const auto open = db::query_one(*writer_,
                                  "SELECT id FROM alerts WHERE dedup_key = ? AND acknowledged = 0 "
                                  "AND resolved_at IS NULL ORDER BY id DESC LIMIT 1",
                                  [](const db::Stmt& s) { return s.i64(0); }, d.dedup_key);
  std::int64_t id = 0;
  if (open) {
    id = *open;
    db::execute(*writer_,
                "UPDATE alerts SET count = count + 1, last_at = ?, message = ?, "
                "severity = MAX(severity, ?), point_index = COALESCE(?, point_index) "
                "WHERE id = ?",
                now, d.message, static_cast<std::int64_t>(d.severity), d.point_index, id);
  } else {
    db::execute(*writer_,
                "INSERT INTO alerts(kind, severity, dedup_key, scan_id, sample_id, "
                "point_index, message, first_at, last_at) VALUES (?,?,?,?,?,?,?,?,?)",
                d.kind, static_cast<std::int64_t>(d.severity), d.dedup_key, d.scan_id, d.sample_id,
                d.point_index, d.message, now, now);
    id = writer_->last_insert_id();
  }
  Alert a = alert_by_id(*writer_, id).value_or(Alert{});
  outbox_in(OutboxRow::Kind::alert, id, 0);
  t.commit();
  outbox_written();
  if (created) *created = !open;
  return a;
}

std::optional<Alert> Store::alert(std::int64_t id) const {
  auto c = read();
  return alert_by_id(*c, id);
}

std::vector<Alert> Store::alerts(const AlertFilter& f) const {
  auto c = read();
  return db::query(*c,
                   fmt::format("SELECT {} FROM alerts WHERE (?1 IS NULL OR acknowledged = ?1) AND "
                               "(?2 IS NULL OR scan_id = ?2) AND severity >= ?3 AND "
                               "(?6 IS NULL OR (resolved_at IS NOT NULL) = ?6) "
                               "ORDER BY id DESC LIMIT ?4 OFFSET ?5",
                               kAlertColumns),
                   read_alert, f.acknowledged, f.scan_id,
                   static_cast<std::int64_t>(f.min_severity.value_or(Severity::info)), f.limit,
                   f.offset, f.resolved);
}

Alert Store::ack_alert(std::int64_t id, const std::string& actor) {
  {
    std::lock_guard lock(write_mu_);
    db::Transaction t(*writer_);
    const auto acknowledged =
        db::query_one(*writer_, "SELECT acknowledged FROM alerts WHERE id = ?",
                      [](const db::Stmt& s) { return s.i64(0) != 0; }, id);
    if (!acknowledged) throw Error::not_found("alert", fmt::format("alert {}", id));
    if (*acknowledged) {
      t.commit();
      return *alert(id);
    }
    db::execute(*writer_,
                "UPDATE alerts SET acknowledged = 1, acknowledged_by = ?, acknowledged_at = ? "
                "WHERE id = ?",
                actor, utc::now(), id);
    db::audit_in(*writer_, actor, "alert.ack", fmt::format("alert:{}", id), json::object());
    outbox_in(OutboxRow::Kind::alert, id, 0);
    t.commit();
    outbox_written();
  }
  return *alert(id);
}

Alert Store::set_alert_message(std::int64_t id, const std::string& message) {
  {
    std::lock_guard lock(write_mu_);
    db::Transaction t(*writer_);
    db::execute(*writer_, "UPDATE alerts SET message = ? WHERE id = ?", message, id);
    if (writer_->changes() == 0) throw Error::not_found("alert", fmt::format("alert {}", id));
    outbox_in(OutboxRow::Kind::alert, id, 0);
    t.commit();
    outbox_written();
  }
  return *alert(id);
}

Alert Store::resolve_alert(std::int64_t id, const std::string& resolution, bool* changed) {
  bool resolved_now = false;
  {
    std::lock_guard lock(write_mu_);
    db::Transaction t(*writer_);
    db::execute(*writer_,
                "UPDATE alerts SET resolved_at = ?, resolution = ? WHERE id = ? AND resolved_at IS NULL",
                utc::now(), resolution, id);
    resolved_now = writer_->changes() != 0;
    if (!resolved_now && !alert_by_id(*writer_, id))
      throw Error::not_found("alert", fmt::format("alert {}", id));
    if (resolved_now) outbox_in(OutboxRow::Kind::alert, id, 0);
    t.commit();
    if (resolved_now) outbox_written();
  }
  if (changed) *changed = resolved_now;
  return *alert(id);
}

}  // namespace gonio::daemon
