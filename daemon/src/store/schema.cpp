// The store's schema: PRAGMA user_version and the migrations that bring a file up to
// Store::kSchemaVersion (store.hpp). A new table is one more migration here.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/proto/error.hpp"
#include "store/sqlite.hpp"

namespace gonio::daemon {

using nlohmann::json;

namespace {

// Migration k brings the schema from version k to k + 1. Never edit a released one.
constexpr const char* kMigrations[] = {
    // 0 -> 1: samples, scans, points, alerts and the audit log.
    R"sql(
CREATE TABLE samples (
  id INTEGER PRIMARY KEY,
  name TEXT NOT NULL UNIQUE,
  notes TEXT NOT NULL DEFAULT '',
  bsdf TEXT,
  tolerance REAL NOT NULL,
  created_at TEXT NOT NULL);
CREATE TABLE scans (
  id INTEGER PRIMARY KEY,
  sample_id INTEGER NOT NULL REFERENCES samples(id),
  plan TEXT NOT NULL,
  state TEXT NOT NULL,
  reason TEXT NOT NULL DEFAULT '',
  predicted INTEGER NOT NULL,
  priority INTEGER NOT NULL,
  queue_pos INTEGER NOT NULL,
  not_before TEXT,
  submitted_by TEXT NOT NULL,
  submitted_at TEXT NOT NULL,
  started_at TEXT,
  finished_at TEXT,
  points_total INTEGER NOT NULL,
  points_done INTEGER NOT NULL DEFAULT 0,
  points_diverged INTEGER NOT NULL DEFAULT 0);
CREATE TABLE points (
  scan_id INTEGER NOT NULL REFERENCES scans(id),
  idx INTEGER NOT NULL,
  geometry_index INTEGER NOT NULL,
  diverged INTEGER NOT NULL,
  finished_at TEXT NOT NULL,
  data TEXT NOT NULL,
  PRIMARY KEY (scan_id, idx)) WITHOUT ROWID;
CREATE TABLE alerts (
  id INTEGER PRIMARY KEY,
  kind TEXT NOT NULL,
  severity INTEGER NOT NULL,
  dedup_key TEXT NOT NULL,
  scan_id INTEGER,
  sample_id INTEGER,
  point_index INTEGER,
  message TEXT NOT NULL,
  first_at TEXT NOT NULL,
  last_at TEXT NOT NULL,
  count INTEGER NOT NULL DEFAULT 1,
  acknowledged INTEGER NOT NULL DEFAULT 0,
  acknowledged_by TEXT NOT NULL DEFAULT '',
  acknowledged_at TEXT);
CREATE TABLE audit (
  id INTEGER PRIMARY KEY,
  at TEXT NOT NULL,
  actor TEXT NOT NULL,
  action TEXT NOT NULL,
  target TEXT NOT NULL DEFAULT '',
  detail TEXT NOT NULL DEFAULT '{}');
)sql",
    // 1 -> 2: API-created tokens (hashes) and the indexes the scheduler and alerts use.
    R"sql(
CREATE TABLE tokens (
  name TEXT PRIMARY KEY,
  role TEXT NOT NULL,
  sha256 TEXT NOT NULL,
  created_at TEXT NOT NULL);
CREATE INDEX scans_by_state ON scans(state, queue_pos);
CREATE INDEX alerts_open ON alerts(dedup_key) WHERE acknowledged = 0;
)sql",
    // 2 -> 3: the inverse twin's results (scan.fit, instrument.calibrate) and the versioned
    // instrument profiles that calibrations produce.
    R"sql(
CREATE TABLE fits (
  id INTEGER PRIMARY KEY,
  scan_id INTEGER NOT NULL REFERENCES scans(id),
  kind TEXT NOT NULL,
  model TEXT NOT NULL,
  created_by TEXT NOT NULL,
  created_at TEXT NOT NULL,
  result TEXT NOT NULL);
CREATE INDEX fits_by_scan ON fits(scan_id, id);
CREATE TABLE profiles (
  version INTEGER PRIMARY KEY,
  name TEXT NOT NULL,
  scan_id INTEGER REFERENCES scans(id),
  fit_id INTEGER REFERENCES fits(id),
  created_by TEXT NOT NULL,
  created_at TEXT NOT NULL,
  profile TEXT NOT NULL);
)sql",
    // 3 -> 4: the archive outbox (docs/architecture.md §11). AUTOINCREMENT: a seq is never
    // reused, even after the rows before it were shipped and removed.
    R"sql(
CREATE TABLE outbox (
  seq INTEGER PRIMARY KEY AUTOINCREMENT,
  kind TEXT NOT NULL,
  ref INTEGER NOT NULL,
  idx INTEGER NOT NULL DEFAULT 0,
  at TEXT NOT NULL,
  detail TEXT);
)sql",
    // 4 -> 5: an alert's resolution (a sustained divergence alert that its scan's final
    // verdict no longer supports). Null while the alert stands.
    R"sql(
ALTER TABLE alerts ADD COLUMN resolved_at TEXT;
ALTER TABLE alerts ADD COLUMN resolution TEXT;
)sql",
    // 5 -> 6: a sample's catalogue uncertainty: the formula's stated u, or the master
    // reference (or the model fitted to one) it was made from (docs/decision-rule.md).
    R"sql(
ALTER TABLE samples ADD COLUMN model_u REAL NOT NULL DEFAULT 0;
ALTER TABLE samples ADD COLUMN catalogue TEXT;
)sql",
    // 6 -> 7: retention (store.retention_days, retention.cpp): the points the central archive
    // has committed (their outbox rows left), and when a scan's points were pruned. The file
    // also moves to auto_vacuum = INCREMENTAL, which takes a VACUUM outside any transaction:
    // migrate() does that after this migration (and at any open that finds it not done).
    R"sql(
ALTER TABLE scans ADD COLUMN points_pruned_at TEXT;
CREATE TABLE archived_points (
  scan_id INTEGER NOT NULL,
  idx INTEGER NOT NULL,
  PRIMARY KEY (scan_id, idx)) WITHOUT ROWID;
)sql",
};
static_assert(std::size(kMigrations) == Store::kSchemaVersion);

int read_version(Store::Connection& c) {
  return db::query_one(c, "PRAGMA user_version", [](const db::Stmt& s) {
           return static_cast<int>(s.i64(0));
         }).value_or(0);
}

}  // namespace

int Store::schema_version() const {
  std::lock_guard lock(write_mu_);
  return read_version(*writer_);
}

void Store::create_at_version(const std::filesystem::path& file, int version) {
  if (version < 0 || version > kSchemaVersion)
    throw Error::out_of_range("version", version, 0, kSchemaVersion);
  Connection c(file, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  if (version == kSchemaVersion) c.exec("PRAGMA auto_vacuum = INCREMENTAL");
  for (int v = 0; v < version; ++v) {
    c.exec(kMigrations[v]);
    c.exec(fmt::format("PRAGMA user_version = {}", v + 1).c_str());
  }
}

void Store::migrate() {
  std::lock_guard lock(write_mu_);
  int version = read_version(*writer_);
  if (version > kSchemaVersion)
    throw Error(Errc::unsupported,
                fmt::format("{} has schema version {}, newer than this goniod understands ({}); "
                            "use a newer goniod",
                            path_.string(), version, kSchemaVersion));
  for (; version < kSchemaVersion; ++version) {
    db::Transaction t(*writer_);
    writer_->exec(kMigrations[version]);
    writer_->exec(fmt::format("PRAGMA user_version = {}", version + 1).c_str());
    db::audit_in(*writer_, "goniod", "store.migrate", "",
                 json{{"from", version}, {"to", version + 1}});
    t.commit();
    spdlog::info("store: migrated {} to schema version {}", path_.string(), version + 1);
  }
  incremental_vacuum_on();
}

void Store::incremental_vacuum_on() {
  // 2: INCREMENTAL (https://www.sqlite.org/pragma.html#pragma_auto_vacuum). A new file takes
  // it before anything is written to it; an existing one only through a VACUUM, which
  // rewrites the file (and needs as much free space again) once.
  // A new file took it before WAL mode first wrote its header (configure_writer).
  const auto mode = db::query_one(*writer_, "PRAGMA auto_vacuum", [](const db::Stmt& s) { return s.i64(0); });
  if (mode == 2) return;
  writer_->begin_write();
  writer_->exec("PRAGMA auto_vacuum = INCREMENTAL");  // what the VACUUM below applies
  spdlog::info("store: rewriting {} once with auto_vacuum = INCREMENTAL (VACUUM), so that pruning returns space",
               path_.string());
  writer_->exec("VACUUM");
  writer_->committed();
}

}  // namespace gonio::daemon
