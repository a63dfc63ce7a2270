// Store — measured points, one row each, keyed (scan_id, idx) (store.hpp).
#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "store/sqlite.hpp"

namespace gonio::daemon {

using nlohmann::json;

void Store::insert_point(const PointRecord& p) { insert_point(p, json(p).dump()); }

void Store::insert_point(const PointRecord& p, const std::string& data) {
  std::lock_guard lock(write_mu_);
  db::Transaction t(*writer_);
  try {
    db::execute(*writer_,
                "INSERT INTO points(scan_id, idx, geometry_index, diverged, finished_at, data) "
                "VALUES (?, ?, ?, ?, ?, ?)",
                p.scan_id, p.index, p.geometry_index, p.diverged, p.finished_at, data);
  } catch (const Error& e) {
    // A constraint failed: the index taken is a point stored twice; any other is not.
    if (e.code() == Errc::invalid_state &&
        !db::query(*writer_, "SELECT 1 FROM points WHERE scan_id = ? AND idx = ?",
                   [](const db::Stmt&) { return true; }, p.scan_id, p.index)
             .empty())
      throw Error::exists("index", fmt::format("point {} of scan {}", p.index, p.scan_id));
    throw;
  }
  db::execute(*writer_,
              "UPDATE scans SET points_done = points_done + 1, "
              "points_diverged = points_diverged + ? WHERE id = ?",
              std::int64_t{p.diverged ? 1 : 0}, p.scan_id);
  outbox_in(OutboxRow::Kind::point, p.scan_id, p.index);
  t.commit();
  outbox_written();
}

std::vector<std::string> Store::point_json(std::int64_t scan_id, std::size_t offset,
                                           std::size_t limit) const {
  auto c = read();
  // Points are stored in order from 0, so index >= offset is the page (and uses the key).
  return db::query(*c, "SELECT data FROM points WHERE scan_id = ? AND idx >= ? ORDER BY idx LIMIT ?",
                   [](const db::Stmt& s) { return s.text(0); }, scan_id, offset, limit);
}

std::vector<PointRecord> Store::points(std::int64_t scan_id, std::size_t offset,
                                       std::size_t limit) const {
  std::vector<PointRecord> out;
  for (const auto& text : point_json(scan_id, offset, limit))
    out.push_back(json::parse(text).get<PointRecord>());
  return out;
}

std::size_t Store::point_count(std::int64_t scan_id) const {
  auto c = read();
  return db::query_one(*c, "SELECT COUNT(*) FROM points WHERE scan_id = ?",
                       [](const db::Stmt& s) { return static_cast<std::size_t>(s.i64(0)); },
                       scan_id)
      .value_or(0);
}

std::int64_t Store::next_point_index(std::int64_t scan_id) const {
  auto c = read();
  return db::query_one(*c, "SELECT COALESCE(MAX(idx) + 1, 0) FROM points WHERE scan_id = ?",
                       [](const db::Stmt& s) { return s.i64(0); }, scan_id)
      .value_or(0);
}

}  // namespace gonio::daemon
