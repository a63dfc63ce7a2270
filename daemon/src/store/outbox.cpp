// Store — the archive outbox (store.hpp, docs/architecture.md §11).
#include <algorithm>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "store/sqlite.hpp"

namespace gonio::daemon {

using nlohmann::json;

// With the write lock held, inside the caller's transaction.
void Store::outbox_in(OutboxRow::Kind kind, std::int64_t ref, std::int64_t idx,
                      const json& detail) {
  if (!outbox_on_.load(std::memory_order_relaxed)) return;
  db::execute(*writer_, "INSERT INTO outbox(kind, ref, idx, at, detail) VALUES (?, ?, ?, ?, ?)",
              std::string(to_text(kind)), ref, idx, utc::now(),
              detail.is_null() ? std::optional<std::string>() : std::optional(detail.dump()));
}

void Store::outbox_written() {
  if (!outbox_on_.load(std::memory_order_relaxed)) return;
  std::lock_guard lock(listener_mu_);
  if (outbox_listener_) outbox_listener_();
}

void Store::set_outbox_listener(std::function<void()> f) {
  std::lock_guard lock(listener_mu_);
  outbox_listener_ = std::move(f);
}

std::vector<OutboxRow> Store::outbox_batch(std::size_t limit, std::int64_t after) const {
  auto c = read();
  return db::query(
      *c,
      "SELECT o.seq, o.kind, o.ref, o.idx, o.at, o.detail, p.data FROM outbox o "
      "LEFT JOIN points p ON o.kind = 'point' AND p.scan_id = o.ref AND p.idx = o.idx "
      "WHERE o.seq > ? ORDER BY o.seq LIMIT ?",
      [](const db::Stmt& s) {
        OutboxRow r;
        r.seq = s.i64(0);
        r.kind = parse_enum<OutboxRow::Kind>(s.text(1), "outbox.kind");
        r.ref = s.i64(2);
        r.idx = s.i64(3);
        r.at = s.text(4);
        if (const auto d = s.opt_text(5)) r.detail = json::parse(*d, nullptr, false);
        if (r.kind == OutboxRow::Kind::point) r.point_json = s.text(6);
        return r;
      },
      after, limit);
}

void Store::outbox_remove(std::int64_t first_seq, std::int64_t last_seq) {
  std::lock_guard lock(write_mu_);
  db::Transaction t(*writer_);
  // The points among them are in the archive now: what retention may prune (retention.cpp).
  db::execute(*writer_,
              "INSERT OR IGNORE INTO archived_points(scan_id, idx) SELECT ref, idx FROM outbox "
              "WHERE seq BETWEEN ? AND ? AND kind = 'point'",
              first_seq, last_seq);
  db::execute(*writer_, "DELETE FROM outbox WHERE seq BETWEEN ? AND ?", first_seq, last_seq);
  t.commit();
}

OutboxStats Store::outbox_stats() const {
  auto c = read();
  // seq order is write order, so the first row is the oldest; MAX - MIN would overcount
  // after a partial removal, COUNT(*) is exact and the outbox stays small when shipping.
  return db::query_one(*c, "SELECT COUNT(*), (SELECT at FROM outbox ORDER BY seq LIMIT 1) FROM outbox",
                       [](const db::Stmt& s) { return OutboxStats{s.i64(0), s.opt_text(1)}; })
      .value_or(OutboxStats{});
}

std::size_t Store::outbox_reship(std::int64_t scan_id, const std::string& actor) {
  std::size_t added = 0;
  {
    std::lock_guard lock(write_mu_);
    db::Transaction t(*writer_);
    const auto sample_id = db::query_one(*writer_, "SELECT sample_id FROM scans WHERE id = ?",
                                         [](const db::Stmt& s) { return s.i64(0); }, scan_id);
    if (!sample_id) throw Error::not_found("scan", fmt::format("scan {}", scan_id));
    const auto now = utc::now();
    db::execute(*writer_,
                "INSERT INTO outbox(kind, ref, idx, at) VALUES ('sample', ?, 0, ?), "
                "('scan', ?, 0, ?)",
                *sample_id, now, scan_id, now);
    db::execute(*writer_,
                "INSERT INTO outbox(kind, ref, idx, at) SELECT 'point', scan_id, idx, ? "
                "FROM points WHERE scan_id = ? ORDER BY idx",
                now, scan_id);
    added = 2 + static_cast<std::size_t>(writer_->changes());
    db::audit_in(*writer_, actor, "archive.reship", fmt::format("scan:{}", scan_id),
                 json{{"rows", added}});
    t.commit();
  }
  std::lock_guard lock(listener_mu_);
  if (outbox_listener_) outbox_listener_();
  return added;
}

}  // namespace gonio::daemon
