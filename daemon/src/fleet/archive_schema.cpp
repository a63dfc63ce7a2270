// The central archive's PostgreSQL schema, versioned (docs/architecture.md §11). goniod
// applies what is missing when its shipper connects, under an advisory lock, so several
// goniods starting against a new database create it once. Never edit a released migration:
// append one.
#include "gonio/daemon/fleet/archive.hpp"

namespace gonio::daemon {

namespace {

// 0 -> 1: the five tables keyed by instrument, the scan state history, the views.
constexpr const char* kTo1 = R"sql(
CREATE TABLE instruments (
  instrument text PRIMARY KEY,
  goniod_version text NOT NULL,
  first_shipped_at timestamptz NOT NULL DEFAULT now(),
  last_shipped_at timestamptz NOT NULL DEFAULT now());

CREATE TABLE samples (
  instrument text NOT NULL REFERENCES instruments,
  sample_id bigint NOT NULL,
  name text NOT NULL,
  notes text NOT NULL,
  bsdf text,
  tolerance double precision NOT NULL,
  created_at timestamptz NOT NULL,
  PRIMARY KEY (instrument, sample_id));
CREATE INDEX samples_by_name ON samples (name);

CREATE TABLE scans (
  instrument text NOT NULL REFERENCES instruments,
  scan_id bigint NOT NULL,
  sample_id bigint NOT NULL,
  state text NOT NULL,
  reason text NOT NULL,
  predicted boolean NOT NULL,
  submitted_by text NOT NULL,
  submitted_at timestamptz NOT NULL,
  started_at timestamptz,
  finished_at timestamptz,
  points_total integer NOT NULL,
  points_done integer NOT NULL,
  points_diverged integer NOT NULL,
  plan jsonb NOT NULL,
  updated_at timestamptz NOT NULL DEFAULT now(),
  PRIMARY KEY (instrument, scan_id),
  FOREIGN KEY (instrument, sample_id) REFERENCES samples);

CREATE TABLE scan_states (
  instrument text NOT NULL,
  scan_id bigint NOT NULL,
  seq bigint NOT NULL,
  state text NOT NULL,
  reason text NOT NULL,
  at timestamptz NOT NULL,
  PRIMARY KEY (instrument, scan_id, seq),
  FOREIGN KEY (instrument, scan_id) REFERENCES scans);

CREATE TABLE points (
  instrument text NOT NULL,
  scan_id bigint NOT NULL,
  idx integer NOT NULL,
  geometry_index integer NOT NULL,
  repeat integer NOT NULL,
  theta_i double precision NOT NULL,
  phi_i double precision NOT NULL,
  theta_r double precision NOT NULL,
  phi_r double precision NOT NULL,
  actual jsonb NOT NULL,
  started_at timestamptz NOT NULL,
  finished_at timestamptz NOT NULL,
  wavelengths double precision[] NOT NULL,
  measured double precision[] NOT NULL,
  measured_u double precision[] NOT NULL,
  predicted double precision[],
  predicted_u double precision[],
  twin_version text NOT NULL,
  z_max double precision,
  delta_e00 double precision,
  diverged boolean NOT NULL,
  flags text[] NOT NULL,
  archived_at timestamptz NOT NULL DEFAULT now(),
  PRIMARY KEY (instrument, scan_id, idx),
  FOREIGN KEY (instrument, scan_id) REFERENCES scans);

CREATE TABLE alerts (
  instrument text NOT NULL REFERENCES instruments,
  alert_id bigint NOT NULL,
  kind text NOT NULL,
  severity text NOT NULL,
  dedup_key text NOT NULL,
  scan_id bigint,
  sample_id bigint,
  point_index bigint,
  message text NOT NULL,
  first_at timestamptz NOT NULL,
  last_at timestamptz NOT NULL,
  count bigint NOT NULL,
  acknowledged boolean NOT NULL,
  acknowledged_by text NOT NULL,
  acknowledged_at timestamptz,
  PRIMARY KEY (instrument, alert_id));
CREATE INDEX alerts_open ON alerts (instrument) WHERE NOT acknowledged;

-- Every point of a sample (by name) across instruments and scans.
CREATE VIEW sample_points AS
  SELECT sm.name AS sample, p.instrument, p.scan_id, p.idx, p.theta_i, p.phi_i, p.theta_r,
         p.phi_r, p.wavelengths, p.measured, p.measured_u, p.predicted, p.predicted_u,
         p.z_max, p.delta_e00, p.diverged, p.finished_at
    FROM points p
    JOIN scans s ON s.instrument = p.instrument AND s.scan_id = p.scan_id
    JOIN samples sm ON sm.instrument = s.instrument AND sm.sample_id = s.sample_id;

-- One row per point and wavelength: what plotting tools and spreadsheets want.
CREATE VIEW point_spectra AS
  SELECT p.instrument, p.scan_id, p.idx, p.theta_i, p.theta_r, p.finished_at,
         w.nm AS wavelength_nm, p.measured[w.i] AS measured, p.measured_u[w.i] AS measured_u,
         p.predicted[w.i] AS predicted, p.predicted_u[w.i] AS predicted_u
    FROM points p, unnest(p.wavelengths) WITH ORDINALITY AS w(nm, i);

-- Each scan with its sample's name and how many of its points the archive holds.
CREATE VIEW scan_summary AS
  SELECT s.instrument, s.scan_id, sm.name AS sample, s.state, s.reason, s.submitted_at,
         s.started_at, s.finished_at, s.points_total, s.points_done, s.points_diverged,
         (SELECT count(*) FROM points p
           WHERE p.instrument = s.instrument AND p.scan_id = s.scan_id) AS points_archived
    FROM scans s
    JOIN samples sm ON sm.instrument = s.instrument AND sm.sample_id = s.sample_id;

-- Alerts nobody has acknowledged yet, on any instrument.
CREATE VIEW open_alerts AS
  SELECT * FROM alerts WHERE NOT acknowledged;
)sql";

// 1 -> 2: the integration time of each point (auto-ranging); null before it was kept.
constexpr const char* kTo2 = R"sql(
ALTER TABLE points ADD COLUMN integration_ms double precision;
CREATE OR REPLACE VIEW sample_points AS
  SELECT sm.name AS sample, p.instrument, p.scan_id, p.idx, p.theta_i, p.phi_i, p.theta_r,
         p.phi_r, p.wavelengths, p.measured, p.measured_u, p.predicted, p.predicted_u,
         p.z_max, p.delta_e00, p.diverged, p.finished_at, p.integration_ms
    FROM points p
    JOIN scans s ON s.instrument = p.instrument AND s.scan_id = p.scan_id
    JOIN samples sm ON sm.instrument = s.instrument AND sm.sample_id = s.sample_id;
)sql";

// 2 -> 3: an alert's resolution (a sustained divergence alert that its scan's final
// verdict no longer supports); open alerts are the unacknowledged ones still standing.
constexpr const char* kTo3 = R"sql(
ALTER TABLE alerts ADD COLUMN resolved_at timestamptz;
ALTER TABLE alerts ADD COLUMN resolution text;
CREATE OR REPLACE VIEW open_alerts AS
  SELECT * FROM alerts WHERE NOT acknowledged AND resolved_at IS NULL;
)sql";

}  // namespace

// Migration i takes the schema from version i to i + 1.
const std::vector<std::string>& archive_migrations() {
  static const std::vector<std::string> m{kTo1, kTo2, kTo3};
  return m;
}

}  // namespace gonio::daemon
