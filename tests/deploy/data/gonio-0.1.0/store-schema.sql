-- The store schema of gonio 0.1.0 (schema version 2): migrations 0 -> 1 and 1 -> 2 of
-- daemon/src/store.cpp as released in 0.1.0, verbatim.
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
CREATE TABLE tokens (
  name TEXT PRIMARY KEY,
  role TEXT NOT NULL,
  sha256 TEXT NOT NULL,
  created_at TEXT NOT NULL);
CREATE INDEX scans_by_state ON scans(state, queue_pos);
CREATE INDEX alerts_open ON alerts(dedup_key) WHERE acknowledged = 0;
PRAGMA user_version = 2;
