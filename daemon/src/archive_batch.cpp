// Outbox rows → the idempotent upserts of one archive transaction (see archive.hpp).
#include <set>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/archive.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/point.hpp"

namespace gonio::daemon {

using nlohmann::json;
using Param = std::optional<std::string>;

namespace {

// PostgreSQL refuses statements with more than 65535 parameters.
constexpr std::size_t kMaxParams = 60000;

std::string num(double v) { return fmt::format("{}", v); }
std::string num(std::int64_t v) { return std::to_string(v); }
std::string flag(bool b) { return b ? "t" : "f"; }
Param opt(const std::optional<double>& v) { return v ? Param(num(*v)) : std::nullopt; }
Param opt(const std::optional<std::int64_t>& v) { return v ? Param(num(*v)) : std::nullopt; }
Param opt(const std::optional<std::string>& v) { return v; }

// "INSERT INTO t (cols) VALUES ($1,..),(..) <tail>" for `rows` rows of `cols` columns.
std::string multi_insert(std::string_view head, std::size_t cols, std::size_t rows,
                         std::string_view tail) {
  std::string sql(head);
  sql += " VALUES ";
  std::size_t n = 1;
  for (std::size_t r = 0; r < rows; ++r) {
    sql += r ? ",(" : "(";
    for (std::size_t c = 0; c < cols; ++c, ++n) {
      if (c) sql += ',';
      sql += '$';
      sql += std::to_string(n);
    }
    sql += ')';
  }
  sql += ' ';
  sql += tail;
  return sql;
}

// Rows of `cols` parameters each become statements of at most kMaxParams parameters.
void emit(std::vector<SqlStatement>& out, std::string_view head, std::size_t cols,
          std::string_view tail, std::vector<Param>&& params) {
  const std::size_t rows = params.size() / cols;
  const std::size_t per = std::max<std::size_t>(1, kMaxParams / cols);
  for (std::size_t first = 0; first < rows; first += per) {
    const std::size_t n = std::min(per, rows - first);
    SqlStatement s;
    s.sql = multi_insert(head, cols, n, tail);
    s.params.assign(std::make_move_iterator(params.begin() + static_cast<std::ptrdiff_t>(first * cols)),
                    std::make_move_iterator(params.begin() + static_cast<std::ptrdiff_t>((first + n) * cols)));
    out.push_back(std::move(s));
  }
}

void append_text_element(std::string& out, const std::string& s) {
  out += '"';
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  out += '"';
}

}  // namespace

std::string pg_float_array(const std::vector<double>& v) {
  std::string out = "{";
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (i) out += ',';
    fmt::format_to(std::back_inserter(out), "{}", v[i]);
  }
  out += '}';
  return out;
}

std::string pg_text_array(const std::vector<std::string>& v) {
  std::string out = "{";
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (i) out += ',';
    append_text_element(out, v[i]);
  }
  out += '}';
  return out;
}

std::vector<SqlStatement> build_archive_batch(const std::string& instrument,
                                              const std::string& goniod_version,
                                              const ArchiveInput& in) {
  std::vector<SqlStatement> out;
  out.push_back({"INSERT INTO instruments (instrument, goniod_version) VALUES ($1, $2) "
                 "ON CONFLICT (instrument) DO UPDATE SET goniod_version = excluded.goniod_version, "
                 "last_shipped_at = now()",
                 {instrument, goniod_version}});

  // Which scans and samples the batch touches: each is upserted once, with its current
  // local record, before the rows that refer to it (the archive's foreign keys).
  std::set<std::int64_t> scan_ids, sample_ids, alert_ids;
  for (const auto& r : in.rows) {
    switch (r.kind) {
      case OutboxRow::Kind::sample: sample_ids.insert(r.ref); break;
      case OutboxRow::Kind::scan:
      case OutboxRow::Kind::point: scan_ids.insert(r.ref); break;
      case OutboxRow::Kind::alert: alert_ids.insert(r.ref); break;
    }
  }
  for (auto id : scan_ids)
    if (const auto it = in.scans.find(id); it != in.scans.end())
      sample_ids.insert(it->second.plan.sample_id);

  std::vector<Param> p;
  for (auto id : sample_ids) {
    const auto it = in.samples.find(id);
    if (it == in.samples.end()) continue;
    const auto& s = it->second;
    p.insert(p.end(), {instrument, num(s.id), s.spec.name, s.spec.notes, opt(s.spec.bsdf),
                       num(s.spec.tolerance), s.created_at});
  }
  if (!p.empty())
    emit(out, "INSERT INTO samples (instrument, sample_id, name, notes, bsdf, tolerance, created_at)",
         7, "ON CONFLICT (instrument, sample_id) DO UPDATE SET name = excluded.name, "
            "notes = excluded.notes, bsdf = excluded.bsdf, tolerance = excluded.tolerance",
         std::move(p));

  p.clear();
  for (auto id : scan_ids) {
    const auto it = in.scans.find(id);
    if (it == in.scans.end()) continue;
    const auto& s = it->second;
    p.insert(p.end(), {instrument, num(s.id), num(s.plan.sample_id), std::string(to_text(s.state)),
                       s.reason, flag(s.predicted), s.submitted_by, s.submitted_at,
                       opt(s.started_at), opt(s.finished_at),
                       num(static_cast<std::int64_t>(s.points_total)),
                       num(static_cast<std::int64_t>(s.points_done)),
                       num(static_cast<std::int64_t>(s.points_diverged)), json(s.plan).dump()});
  }
  if (!p.empty())
    emit(out, "INSERT INTO scans (instrument, scan_id, sample_id, state, reason, predicted, "
              "submitted_by, submitted_at, started_at, finished_at, points_total, points_done, "
              "points_diverged, plan)",
         14, "ON CONFLICT (instrument, scan_id) DO UPDATE SET state = excluded.state, "
             "reason = excluded.reason, started_at = excluded.started_at, "
             "finished_at = excluded.finished_at, points_done = excluded.points_done, "
             "points_diverged = excluded.points_diverged, updated_at = now()",
         std::move(p));

  // State history: one row per change, keyed by the outbox seq that carried it.
  p.clear();
  for (const auto& r : in.rows) {
    if (r.kind != OutboxRow::Kind::scan || !r.detail.is_object() || !in.scans.contains(r.ref))
      continue;
    p.insert(p.end(), {instrument, num(r.ref), num(r.seq), r.detail.value("state", ""),
                       r.detail.value("reason", ""), r.at});
  }
  if (!p.empty())
    emit(out, "INSERT INTO scan_states (instrument, scan_id, seq, state, reason, at)", 6,
         "ON CONFLICT DO NOTHING", std::move(p));

  // Points, in outbox order; a point already archived is left as it is.
  p.clear();
  std::set<std::pair<std::int64_t, std::int64_t>> seen;
  for (const auto& r : in.rows) {
    if (r.kind != OutboxRow::Kind::point || !in.scans.contains(r.ref)) continue;
    if (!seen.emplace(r.ref, r.idx).second) continue;  // re-shipped within the batch
    if (r.point_json.empty()) {
      spdlog::error("archive: point {} of scan {} is in the outbox but not in the store", r.idx, r.ref);
      continue;
    }
    PointRecord pt;
    try {
      pt = json::parse(r.point_json).get<PointRecord>();
    } catch (const std::exception& e) {
      throw Error(Errc::internal, fmt::format("archive: point {} of scan {} is unreadable: {}",
                                              r.idx, r.ref, e.what()));
    }
    const json actual = pt.actual;
    p.insert(p.end(),
             {instrument, num(pt.scan_id), num(pt.index), num(pt.geometry_index),
              num(std::int64_t{pt.repeat}), num(pt.planned.theta_i), num(pt.planned.phi_i),
              num(pt.planned.theta_r), num(pt.planned.phi_r), actual.dump(), pt.started_at,
              pt.finished_at, pg_float_array(pt.measured.wavelengths.values()),
              pg_float_array(pt.measured.values), pg_float_array(pt.measured.std_uncertainty),
              pt.predicted ? Param(pg_float_array(pt.predicted->values)) : std::nullopt,
              pt.predicted ? Param(pg_float_array(pt.predicted->std_uncertainty)) : std::nullopt,
              pt.twin_version, opt(pt.z_max), opt(pt.delta_e00), flag(pt.diverged),
              pg_text_array(pt.flags)});
  }
  if (!p.empty())
    emit(out, "INSERT INTO points (instrument, scan_id, idx, geometry_index, repeat, theta_i, "
              "phi_i, theta_r, phi_r, actual, started_at, finished_at, wavelengths, measured, "
              "measured_u, predicted, predicted_u, twin_version, z_max, delta_e00, diverged, flags)",
         22, "ON CONFLICT (instrument, scan_id, idx) DO NOTHING", std::move(p));

  p.clear();
  for (auto id : alert_ids) {
    const auto it = in.alerts.find(id);
    if (it == in.alerts.end()) continue;
    const auto& a = it->second;
    p.insert(p.end(), {instrument, num(a.id), a.kind, std::string(to_text(a.severity)), a.dedup_key,
                       opt(a.scan_id), opt(a.sample_id), opt(a.point_index), a.message, a.first_at,
                       a.last_at, num(a.count), flag(a.acknowledged), a.acknowledged_by,
                       opt(a.acknowledged_at)});
  }
  if (!p.empty())
    emit(out, "INSERT INTO alerts (instrument, alert_id, kind, severity, dedup_key, scan_id, "
              "sample_id, point_index, message, first_at, last_at, count, acknowledged, "
              "acknowledged_by, acknowledged_at)",
         15, "ON CONFLICT (instrument, alert_id) DO UPDATE SET severity = excluded.severity, "
             "point_index = excluded.point_index, message = excluded.message, "
             "last_at = excluded.last_at, count = excluded.count, "
             "acknowledged = excluded.acknowledged, acknowledged_by = excluded.acknowledged_by, "
             "acknowledged_at = excluded.acknowledged_at",
         std::move(p));
  return out;
}

}  // namespace gonio::daemon
