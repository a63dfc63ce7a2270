// Outbox rows → the idempotent upserts of one archive transaction (see archive.hpp).
#include <set>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/fleet/archive.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {

using nlohmann::json;
using Param = std::optional<std::string>;

namespace {

// PostgreSQL refuses statements with more than 65535 parameters.
constexpr std::size_t kMaxParams = 60000;

std::string num(double v) { return fmt::format("{}", v); }
std::string num(std::int64_t v) { return std::to_string(v); }
std::string flag(bool b) { return b ? "t" : "f"; }
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

// A JSON array of numbers as a PostgreSQL array literal; null stays NULL.
Param json_float_array(const json& a) {
  if (a.is_null()) return std::nullopt;
  std::string out = "{";
  for (const auto& v : a) {
    if (out.size() > 1) out += ',';
    fmt::format_to(std::back_inserter(out), "{}", v.get<double>());
  }
  out += '}';
  return out;
}

Param json_opt_number(const json& v) {
  if (v.is_null()) return std::nullopt;
  return num(v.get<double>());
}

// The 23 columns of a points row, read straight from the point's stored JSON (what
// PointRecord's to_json wrote; the store validated it then): no PointRecord and no second
// validation, which made up most of a batch's client time.
void append_point(std::vector<Param>& p, const std::string& instrument, const json& pt) {
  const auto& planned = pt.at("planned");
  const auto& measured = pt.at("measured");
  const auto& predicted = pt.at("predicted");
  std::string flags = "{";
  for (const auto& f : pt.at("flags")) {
    if (flags.size() > 1) flags += ',';
    append_text_element(flags, f.get<std::string>());
  }
  flags += '}';
  p.insert(p.end(),
           {instrument, num(pt.at("scan_id").get<std::int64_t>()), num(pt.at("index").get<std::int64_t>()),
            num(pt.at("geometry_index").get<std::int64_t>()), num(pt.at("repeat").get<std::int64_t>()),
            num(planned.at("theta_i").get<double>()), num(planned.at("phi_i").get<double>()),
            num(planned.at("theta_r").get<double>()), num(planned.at("phi_r").get<double>()),
            pt.at("actual").dump(), pt.at("started_at").get<std::string>(),
            pt.at("finished_at").get<std::string>(), json_float_array(measured.at("wavelengths_nm")),
            json_float_array(measured.at("values")), json_float_array(measured.at("std_uncertainty")),
            predicted.is_null() ? std::nullopt : json_float_array(predicted.at("values")),
            predicted.is_null() ? std::nullopt : json_float_array(predicted.at("std_uncertainty")),
            pt.at("twin_version").get<std::string>(), json_opt_number(pt.at("z_max")),
            json_opt_number(pt.at("delta_e00")), flag(pt.at("diverged").get<bool>()), std::move(flags),
            pt.contains("integration_ms") ? json_opt_number(pt.at("integration_ms")) : Param()});
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
    try {
      append_point(p, instrument, json::parse(r.point_json));
    } catch (const std::exception& e) {
      throw Error(Errc::internal, fmt::format("archive: point {} of scan {} is unreadable: {}",
                                              r.idx, r.ref, e.what()));
    }
  }
  if (!p.empty())
    emit(out, "INSERT INTO points (instrument, scan_id, idx, geometry_index, repeat, theta_i, "
              "phi_i, theta_r, phi_r, actual, started_at, finished_at, wavelengths, measured, "
              "measured_u, predicted, predicted_u, twin_version, z_max, delta_e00, diverged, flags, "
              "integration_ms)",
         23, "ON CONFLICT (instrument, scan_id, idx) DO NOTHING", std::move(p));

  p.clear();
  for (auto id : alert_ids) {
    const auto it = in.alerts.find(id);
    if (it == in.alerts.end()) continue;
    const auto& a = it->second;
    p.insert(p.end(), {instrument, num(a.id), a.kind, std::string(to_text(a.severity)), a.dedup_key,
                       opt(a.scan_id), opt(a.sample_id), opt(a.point_index), a.message, a.first_at,
                       a.last_at, num(a.count), flag(a.acknowledged), a.acknowledged_by,
                       opt(a.acknowledged_at), opt(a.resolved_at), opt(a.resolution)});
  }
  if (!p.empty())
    emit(out, "INSERT INTO alerts (instrument, alert_id, kind, severity, dedup_key, scan_id, "
              "sample_id, point_index, message, first_at, last_at, count, acknowledged, "
              "acknowledged_by, acknowledged_at, resolved_at, resolution)",
         17, "ON CONFLICT (instrument, alert_id) DO UPDATE SET severity = excluded.severity, "
             "point_index = excluded.point_index, message = excluded.message, "
             "last_at = excluded.last_at, count = excluded.count, "
             "acknowledged = excluded.acknowledged, acknowledged_by = excluded.acknowledged_by, "
             "acknowledged_at = excluded.acknowledged_at, resolved_at = excluded.resolved_at, "
             "resolution = excluded.resolution",
         std::move(p));
  return out;
}

}  // namespace gonio::daemon
