// Store — retention: pruning the points the central archive holds (store.hpp).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/proto/error.hpp"
#include "store/sqlite.hpp"

namespace gonio::daemon {

using nlohmann::json;

namespace {

// Finished before ?1, not yet pruned, with points, every one of them committed by the
// archive, and no outbox row of the scan still waiting (its final state included).
constexpr const char* kPrunable = R"sql(
SELECT s.id FROM scans s
WHERE s.state IN ('completed', 'failed', 'cancelled') AND s.finished_at < ?1
  AND s.points_pruned_at IS NULL
  AND EXISTS (SELECT 1 FROM points p WHERE p.scan_id = s.id)
  AND NOT EXISTS (SELECT 1 FROM points p WHERE p.scan_id = s.id AND NOT EXISTS
                    (SELECT 1 FROM archived_points a WHERE a.scan_id = p.scan_id AND a.idx = p.idx))
  AND NOT EXISTS (SELECT 1 FROM outbox o WHERE o.ref = s.id AND o.kind IN ('scan', 'point'))
ORDER BY s.id LIMIT ?2
)sql";

}  // namespace

Store::PruneResult Store::prune_archived(const std::string& before, std::size_t max_scans) {
  PruneResult r;
  std::vector<std::int64_t> ids;
  {
    auto c = read();
    ids = db::query(*c, kPrunable, [](const db::Stmt& s) { return s.i64(0); }, before, max_scans);
  }
  for (const auto id : ids) {
    std::lock_guard lock(write_mu_);
    db::Transaction t(*writer_);
    // Checked again inside the write: a reship may have queued the scan since.
    const auto still = db::query_one(*writer_,
                                     "SELECT 1 FROM outbox WHERE ref = ? AND kind IN ('scan', 'point') LIMIT 1",
                                     [](const db::Stmt&) { return 1; }, id);
    if (still) continue;
    db::execute(*writer_, "DELETE FROM points WHERE scan_id = ?", id);
    r.points += writer_->changes();
    db::execute(*writer_, "DELETE FROM archived_points WHERE scan_id = ?", id);
    db::execute(*writer_, "UPDATE scans SET points_pruned_at = ? WHERE id = ?", utc::now(), id);
    t.commit();
    ++r.scans;
  }
  if (r.scans > 0) {
    audit("goniod", "store.prune", "", json{{"scans", r.scans}, {"points", r.points}, {"before", before}});
    r.pages_freed = release_free_pages();
  }
  return r;
}

std::optional<std::string> Store::points_pruned_at(std::int64_t id) const {
  auto c = read();
  return db::query_one(*c, "SELECT points_pruned_at FROM scans WHERE id = ?",
                       [](const db::Stmt& s) { return s.opt_text(0); }, id)
      .value_or(std::nullopt);
}

std::int64_t Store::release_free_pages(int pages_per_step) {
  std::int64_t freed = 0;
  for (;;) {
    std::lock_guard lock(write_mu_);
    const auto free_pages =
        db::query_one(*writer_, "PRAGMA freelist_count", [](const db::Stmt& s) { return s.i64(0); }).value_or(0);
    if (free_pages == 0) break;
    writer_->begin_write();
    // https://www.sqlite.org/pragma.html#pragma_incremental_vacuum: one write transaction.
    writer_->exec(fmt::format("PRAGMA incremental_vacuum({})", pages_per_step).c_str());
    writer_->committed();
    const auto left =
        db::query_one(*writer_, "PRAGMA freelist_count", [](const db::Stmt& s) { return s.i64(0); }).value_or(0);
    freed += free_pages - left;
    if (left >= free_pages) break;  // not in incremental mode: nothing moves
  }
  return freed;
}

}  // namespace gonio::daemon
