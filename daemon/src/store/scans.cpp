// Store — scans and the order of the queue (store.hpp).
#include <algorithm>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "store/sqlite.hpp"

namespace gonio::daemon {

using nlohmann::json;

namespace {

constexpr const char* kScanColumns =
    "id, sample_id, plan, state, reason, predicted, queue_pos, submitted_by, submitted_at, "
    "started_at, finished_at, points_total, points_done, points_diverged";

// The states a scan waits in, in the queue.
constexpr const char* kWaiting = "state IN ('queued','paused','interrupted')";

Scan read_scan(const db::Stmt& s) {
  Scan sc;
  sc.id = s.i64(0);
  try {
    sc.plan = json::parse(s.text(2)).get<ScanPlan>();
  } catch (const std::exception& e) {
    throw Error(Errc::internal, fmt::format("store: scan {} has an unreadable plan: {}", sc.id,
                                            e.what()));
  }
  sc.plan.sample_id = s.i64(1);
  sc.state = parse_enum<ScanState>(s.text(3), "state");
  sc.reason = s.text(4);
  sc.predicted = s.i64(5) != 0;
  sc.queue_position = s.i64(6);
  sc.submitted_by = s.text(7);
  sc.submitted_at = s.text(8);
  sc.started_at = s.opt_text(9);
  sc.finished_at = s.opt_text(10);
  sc.points_total = static_cast<std::size_t>(s.i64(11));
  sc.points_done = static_cast<std::size_t>(s.i64(12));
  sc.points_diverged = static_cast<std::size_t>(s.i64(13));
  return sc;
}

std::int64_t scan_id_of(const db::Stmt& s) { return s.i64(0); }

// Waiting scans in queue order (ids).
std::vector<std::int64_t> waiting_ids(db::Connection& c) {
  return db::query(c, fmt::format("SELECT id FROM scans WHERE {} ORDER BY queue_pos, id", kWaiting),
                   scan_id_of);
}

void renumber(db::Connection& c, const std::vector<std::int64_t>& ids) {
  for (std::size_t i = 0; i < ids.size(); ++i)
    db::execute(c, "UPDATE scans SET queue_pos = ? WHERE id = ?", i, ids[i]);
}

}  // namespace

Scan Store::insert_scan(const ScanPlan& plan, bool predicted, const std::string& actor) {
  std::lock_guard lock(write_mu_);
  db::Transaction t(*writer_);
  // Insert after every waiting scan of the same or a higher priority.
  std::vector<std::int64_t> ids;
  std::size_t insert_at = 0;
  {
    db::Stmt s(*writer_, fmt::format("SELECT id, priority FROM scans WHERE {} ORDER BY queue_pos, id",
                                     kWaiting));
    while (s.step()) {
      ids.push_back(s.i64(0));
      if (s.i64(1) >= plan.priority) insert_at = ids.size();
    }
  }
  Scan sc;
  sc.plan = plan;
  sc.state = ScanState::queued;
  sc.predicted = predicted;
  sc.submitted_by = actor;
  sc.submitted_at = utc::now();
  sc.points_total = plan.point_count();
  const json stored = plan;
  db::execute(*writer_,
              "INSERT INTO scans(sample_id, plan, state, predicted, priority, queue_pos, "
              "not_before, submitted_by, submitted_at, points_total) "
              "VALUES (?, ?, 'queued', ?, ?, 0, ?, ?, ?, ?)",
              plan.sample_id, stored.dump(), predicted, plan.priority, plan.not_before, actor,
              sc.submitted_at, sc.points_total);
  sc.id = writer_->last_insert_id();
  ids.insert(ids.begin() + static_cast<std::ptrdiff_t>(insert_at), sc.id);
  renumber(*writer_, ids);
  sc.queue_position = static_cast<std::int64_t>(insert_at);
  db::audit_in(*writer_, actor, "scan.submit", fmt::format("scan:{}", sc.id),
               json{{"sample", plan.sample_id},
                    {"points", sc.points_total},
                    {"priority", plan.priority}});
  outbox_in(OutboxRow::Kind::scan, sc.id, 0, json{{"state", "queued"}, {"reason", ""}});
  t.commit();
  outbox_written();
  return sc;
}

std::optional<Scan> Store::scan(std::int64_t id) const {
  auto c = read();
  return db::query_one(*c, fmt::format("SELECT {} FROM scans WHERE id = ?", kScanColumns),
                       read_scan, id);
}

std::optional<std::pair<std::size_t, std::size_t>> Store::scan_progress(std::int64_t id) const {
  auto c = read();
  return db::query_one(
      *c, "SELECT points_done, points_total FROM scans WHERE id = ?",
      [](const db::Stmt& s) {
        return std::make_pair(static_cast<std::size_t>(s.i64(0)), static_cast<std::size_t>(s.i64(1)));
      },
      id);
}

std::vector<Scan> Store::scans(const ScanFilter& f) const {
  auto c = read();
  const std::optional<std::string> state =
      f.state ? std::optional<std::string>(to_text(*f.state)) : std::nullopt;
  return db::query(*c,
                   fmt::format("SELECT {} FROM scans WHERE (?1 IS NULL OR state = ?1) AND "
                               "(?2 IS NULL OR sample_id = ?2) AND (?5 IS NULL OR submitted_at >= ?5) AND "
                               "(?6 IS NULL OR submitted_at < ?6) AND (?7 IS NULL OR "
                               "instr(lower(coalesce(json_extract(plan, '$.name'), '')), lower(?7)) > 0) "
                               "ORDER BY id DESC LIMIT ?3 OFFSET ?4",
                               kScanColumns),
                   read_scan, state, f.sample_id, f.limit, f.offset, f.since, f.until, f.text);
}

std::vector<Scan> Store::queue() const {
  auto c = read();
  return db::query(
      *c, fmt::format("SELECT {} FROM scans WHERE {} ORDER BY queue_pos, id", kScanColumns, kWaiting),
      read_scan);
}

std::optional<Scan> Store::next_runnable(const std::string& now_iso,
                                         std::optional<std::string>* earliest) const {
  auto c = read();
  if (auto sc = db::query_one(*c,
                              fmt::format("SELECT {} FROM scans WHERE state = 'interrupted' "
                                          "ORDER BY queue_pos, id LIMIT 1",
                                          kScanColumns),
                              read_scan))
    return sc;
  // ISO-8601 UTC strings of one format compare like the times they name.
  if (auto sc = db::query_one(*c,
                              fmt::format("SELECT {} FROM scans WHERE state = 'queued' AND "
                                          "(not_before IS NULL OR not_before <= ?) "
                                          "ORDER BY queue_pos, id LIMIT 1",
                                          kScanColumns),
                              read_scan, now_iso))
    return sc;
  if (earliest)
    *earliest = db::query_one(*c,
                              "SELECT MIN(not_before) FROM scans WHERE state = 'queued' AND "
                              "not_before > ?",
                              [](const db::Stmt& s) { return s.opt_text(0); }, now_iso)
                    .value_or(std::nullopt);
  return std::nullopt;
}

void Store::set_scan_state(std::int64_t id, ScanState state, const std::string& reason,
                           const std::string& actor) {
  std::lock_guard lock(write_mu_);
  db::Transaction t(*writer_);
  const auto old = db::query_one(*writer_, "SELECT state FROM scans WHERE id = ?",
                                 [](const db::Stmt& s) { return s.text(0); }, id);
  if (!old) throw Error::not_found("scan", fmt::format("scan {}", id));
  db::execute(*writer_,
              "UPDATE scans SET state = ?1, reason = ?2, "
              "started_at = CASE WHEN ?1 = 'running' AND started_at IS NULL THEN ?3 "
              "ELSE started_at END, "
              "finished_at = CASE WHEN ?1 IN ('completed','failed','cancelled') THEN ?3 "
              "ELSE finished_at END WHERE id = ?4",
              std::string(to_text(state)), reason, utc::now(), id);
  db::audit_in(*writer_, actor, "scan.state", fmt::format("scan:{}", id),
               json{{"from", *old}, {"to", to_text(state)}, {"reason", reason}});
  outbox_in(OutboxRow::Kind::scan, id, 0, json{{"state", to_text(state)}, {"reason", reason}});
  t.commit();
  outbox_written();
}

void Store::reorder(std::int64_t id, std::size_t position, const std::string& actor) {
  std::lock_guard lock(write_mu_);
  db::Transaction t(*writer_);
  auto ids = waiting_ids(*writer_);
  const auto it = std::find(ids.begin(), ids.end(), id);
  if (it == ids.end())
    throw Error::wrong_state("scan", fmt::format("scan {} is not waiting in the queue (only "
                                                 "queued, paused or interrupted scans can be moved)",
                                                 id));
  ids.erase(it);
  position = std::min(position, ids.size());
  ids.insert(ids.begin() + static_cast<std::ptrdiff_t>(position), id);
  renumber(*writer_, ids);
  db::audit_in(*writer_, actor, "queue.reorder", fmt::format("scan:{}", id),
               json{{"position", position}});
  t.commit();
}

std::vector<std::int64_t> Store::recover_running(const std::string& reason) {
  std::lock_guard lock(write_mu_);
  db::Transaction t(*writer_);
  const auto ids = db::query(*writer_, "SELECT id FROM scans WHERE state = 'running'", scan_id_of);
  for (auto id : ids) {
    db::execute(*writer_, "UPDATE scans SET state = 'interrupted', reason = ? WHERE id = ?",
                reason, id);
    db::audit_in(*writer_, "goniod", "scan.state", fmt::format("scan:{}", id),
                 json{{"from", "running"}, {"to", "interrupted"}, {"reason", reason}});
    outbox_in(OutboxRow::Kind::scan, id, 0, json{{"state", "interrupted"}, {"reason", reason}});
  }
  t.commit();
  if (!ids.empty()) outbox_written();
  return ids;
}

}  // namespace gonio::daemon
