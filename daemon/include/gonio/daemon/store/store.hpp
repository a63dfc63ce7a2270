// Store — the daemon's durable state in one SQLite file (WAL mode) in the state dir.
//
// Tables: samples, scans (plan as JSON, state, queue position), points (one row per
// measured point, primary key (scan_id, idx), so a point can never be stored twice),
// alerts, audit (who did what, when), tokens (hashes only), fits (inverse-twin results per
// scan), profiles (calibrated instrument profiles, versioned) and outbox (what the central
// archive has not yet committed). The schema version is
// PRAGMA user_version; migrations run in order inside a transaction at open, and a file
// written by a newer goniod is refused rather than guessed at.
//
// Storage failures (storage.hpp): a write that fails because the disk is full, the file
// system read-only or the disk failing (SQLITE_FULL, SQLITE_IOERR_*, SQLITE_READONLY,
// SQLITE_CANTOPEN) makes the store read-only: reads go on, and every write is refused with
// Error(storage_unavailable) naming the directory and its free space, until the space is
// back (store.min_free_mb plus the reserve) and a write succeeds again (probe() tries one).
// The reserve file beside the database is released at SQLITE_FULL, so that the pause of
// the running scan and its alert, written inside an Essential scope, still find room.
//
// Durability: with synchronous = FULL every committed point is on disk (WAL fsynced)
// before insert_point() returns, which is what lets the scan runner move the arms only
// after the previous point is safe. Writes go through one connection under a mutex;
// reads use a small pool of their own connections, which WAL lets run beside a writer.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gonio/daemon/config/config.hpp"
#include "gonio/daemon/store/storage.hpp"
#include "gonio/proto/alert.hpp"
#include "gonio/proto/enum_text.hpp"
#include "gonio/proto/point.hpp"
#include "gonio/proto/sample.hpp"
#include "gonio/proto/scan.hpp"

struct sqlite3;

namespace gonio::daemon {

struct AuditEvent {
  std::int64_t id = 0;
  std::string at;
  std::string actor;
  std::string action;   // "scan.submit", "alert.ack", "daemon.start", ...
  std::string target;   // "scan:12", "sample:glossy", ""
  nlohmann::json detail = nlohmann::json::object();
};

// What a caller asks to raise; the store deduplicates on dedup_key.
struct AlertDraft {
  std::string kind;
  Severity severity = Severity::warning;
  std::string dedup_key;
  std::optional<std::int64_t> scan_id{}, sample_id{}, point_index{};
  std::string message;
};

// What a stored fit record is: a material fit (scan.fit), an instrument calibration, a
// divergence diagnosis, the scan's verdict (verdict.hpp) or an adaptive scan's last design
// status (twin/design.hpp). Stored and sent as its name.
enum class FitKind { fit, calibrate, diagnosis, verdict, adaptive };
inline constexpr EnumNames<FitKind, 5> kFitKindNames{{
    {FitKind::fit, "fit"},
    {FitKind::calibrate, "calibrate"},
    {FitKind::diagnosis, "diagnosis"},
    {FitKind::verdict, "verdict"},
    {FitKind::adaptive, "adaptive"},
}};
constexpr const auto& enum_names(FitKind) { return kFitKindNames; }  // proto/enum_text.hpp

// A result of the inverse twin kept with its scan (scan.fit, instrument.calibrate).
struct StoredFit {
  std::int64_t id = 0;
  std::int64_t scan_id = 0;
  FitKind kind = FitKind::fit;
  std::string model;  // the model spec (fit) or the known sample's spec (calibrate)
  std::string created_by, created_at;
  nlohmann::json result;  // gonio::twin::FitResult::to_json()
};

// An instrument profile made by a calibration; versions count up from 1.
struct StoredProfile {
  std::int64_t version = 0;
  std::string name;
  std::optional<std::int64_t> scan_id, fit_id;  // the calibration that made it
  std::string created_by, created_at;
  nlohmann::json profile;  // gonio::twin::InstrumentProfile as JSON
};

// One row of the archive outbox (docs/architecture.md §11): something committed locally that
// the archive shipper owes the central archive. Rows are written in the same transaction as
// what they mirror and leave only when the archive has committed them.
struct OutboxRow {
  enum class Kind { sample, scan, point, alert };
  std::int64_t seq = 0;     // increasing, never reused: the shipping order
  Kind kind = Kind::point;
  std::int64_t ref = 0;     // sample id, scan id (scan, point) or alert id
  std::int64_t idx = 0;     // point index (point rows)
  std::string at;           // when it was written (UTC ISO-8601)
  nlohmann::json detail;    // scan rows: the state change {state, reason}; else null
  std::string point_json;   // point rows: the stored point (joined when read)
};
inline constexpr EnumNames<OutboxRow::Kind, 4> kOutboxKindNames{{
    {OutboxRow::Kind::sample, "sample"},
    {OutboxRow::Kind::scan, "scan"},
    {OutboxRow::Kind::point, "point"},
    {OutboxRow::Kind::alert, "alert"},
}};
constexpr const auto& enum_names(OutboxRow::Kind) { return kOutboxKindNames; }

struct OutboxStats {
  std::int64_t rows = 0;             // waiting
  std::optional<std::string> oldest_at;  // of the oldest waiting row
};

struct ScanFilter {
  std::optional<ScanState> state;
  std::optional<std::int64_t> sample_id;
  // submitted_at in [since, until), as utc::format writes it (so text order is time order)
  std::optional<std::string> since, until;
  std::optional<std::string> text;  // in the label (plan.name), ASCII case ignored
  std::size_t offset = 0, limit = 100;
};

struct AlertFilter {
  std::optional<bool> acknowledged;
  std::optional<bool> resolved;  // false: standing ones only; true: resolved ones only
  std::optional<std::int64_t> scan_id;
  std::optional<Severity> min_severity;
  std::size_t offset = 0, limit = 100;
};

class Store {
 public:
  static constexpr int kSchemaVersion = 7;

  // Opens (creating) the database; runs migrations. Throws Error(io_error) when the file
  // cannot be opened, Error(unsupported) when it is newer than this build.
  Store(const std::filesystem::path& file, bool synchronous_full = true);
  ~Store();
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;

  // Writes a new, empty store at an older schema `version` (0..kSchemaVersion), as an older
  // goniod would have left it: what upgrade tests start from.
  static void create_at_version(const std::filesystem::path& file, int version);

  int schema_version() const;
  const std::filesystem::path& path() const noexcept { return path_; }

  // ---- samples
  // Throws Error(invalid_state) naming "name" when the name is taken.
  // `catalogue`: JSON text of a catalogue made from a master (Sample::catalogue), or empty.
  Sample create_sample(const SampleSpec& spec, const std::string& actor,
                       const std::string& catalogue = {});
  std::optional<Sample> sample(std::int64_t id) const;
  std::optional<Sample> sample_by_name(const std::string& name) const;
  std::vector<Sample> samples(std::size_t offset = 0, std::size_t limit = 1000) const;

  // ---- scans
  Scan insert_scan(const ScanPlan& plan, bool predicted, const std::string& actor);
  std::optional<Scan> scan(std::int64_t id) const;
  // (points_done, points_total) without reading the plan.
  std::optional<std::pair<std::size_t, std::size_t>> scan_progress(std::int64_t id) const;
  std::vector<Scan> scans(const ScanFilter& filter) const;
  // Waiting scans (queued, paused, interrupted) in queue order.
  std::vector<Scan> queue() const;
  // The scan to run next: interrupted ones first (they were running), then queued ones whose
  // not-before time has passed, in queue order. `earliest_not_before` receives the nearest
  // future not-before time among queued scans, if any.
  std::optional<Scan> next_runnable(const std::string& now_iso,
                                    std::optional<std::string>* earliest_not_before = nullptr) const;
  // Sets the state (and reason); started_at is set on the first transition to running,
  // finished_at on a final state. Writes an audit event in the same transaction.
  void set_scan_state(std::int64_t id, ScanState state, const std::string& reason,
                      const std::string& actor);
  // Moves a waiting scan to `position` (0 = first) among the waiting scans.
  void reorder(std::int64_t id, std::size_t position, const std::string& actor);
  // At start-up: every scan left `running` by a crash becomes `interrupted`. Returns them.
  std::vector<std::int64_t> recover_running(const std::string& reason);

  // ---- points
  // Inserts the point and updates the scan's counters in one transaction. Throws
  // Error(invalid_state) when that point is already stored.
  void insert_point(const PointRecord& p);
  // The same with the point's JSON text already made (the runner also notifies with it).
  void insert_point(const PointRecord& p, const std::string& json_text);
  std::vector<PointRecord> points(std::int64_t scan_id, std::size_t offset, std::size_t limit) const;
  // Raw JSON text of points (what scan.points serves without re-encoding).
  std::vector<std::string> point_json(std::int64_t scan_id, std::size_t offset,
                                      std::size_t limit) const;
  std::size_t point_count(std::int64_t scan_id) const;
  // The lowest point index not yet stored (= count when points are stored in order).
  std::int64_t next_point_index(std::int64_t scan_id) const;

  // ---- alerts
  // Inserts a new alert or, while one with the same dedup_key is unacknowledged and standing, bumps its
  // count, last_at, severity (never lowered), point and message. `created` tells which.
  Alert raise_alert(const AlertDraft& draft, bool* created = nullptr);
  std::optional<Alert> alert(std::int64_t id) const;
  std::vector<Alert> alerts(const AlertFilter& filter) const;
  // Throws Error(not_found); acknowledging twice is allowed and keeps the first ack.
  Alert ack_alert(std::int64_t id, const std::string& actor);
  // Replaces an alert's message (a diagnosis appended later); count and times unchanged.
  Alert set_alert_message(std::int64_t id, const std::string& message);
  // Marks alert `id` resolved now with `resolution`; `changed` says whether it stood until
  // now (resolving twice keeps the first). A resolved alert no longer takes repeats of its
  // dedup_key: the next raise opens a new one. Throws Error(not_found).
  Alert resolve_alert(std::int64_t id, const std::string& resolution, bool* changed = nullptr);

  // ---- fits and profiles
  StoredFit insert_fit(std::int64_t scan_id, FitKind kind, const std::string& model,
                       const nlohmann::json& result, const std::string& actor);
  // The scan's fits, newest first (its verdicts are not fits: latest_fit(id, FitKind::verdict)).
  std::vector<StoredFit> fits(std::int64_t scan_id, std::size_t limit) const;
  // The newest record of `kind` of a scan.
  std::optional<StoredFit> latest_fit(std::int64_t scan_id, FitKind kind) const;
  // Stores `profile` as the next version (audited).
  StoredProfile insert_profile(const std::string& name, const nlohmann::json& profile,
                               std::optional<std::int64_t> scan_id,
                               std::optional<std::int64_t> fit_id, const std::string& actor);
  std::optional<StoredProfile> latest_profile() const;

  // ---- archive outbox (docs/architecture.md §11)
  // While on, every committed sample, scan (and state change), point and alert also writes
  // an outbox row in its own transaction. Off by default: goniod turns it on with [archive].
  void set_outbox(bool on) noexcept { outbox_on_.store(on); }
  bool outbox() const noexcept { return outbox_on_.load(); }
  // Called after each transaction that wrote outbox rows, with the write lock held: it must
  // only wake someone, never call back into the store.
  void set_outbox_listener(std::function<void()> f);
  // The oldest `limit` rows after seq `after` (0: from the first), in seq order, points with
  // their stored JSON.
  std::vector<OutboxRow> outbox_batch(std::size_t limit, std::int64_t after = 0) const;
  // Removes rows first_seq..last_seq (what one batch shipped).
  void outbox_remove(std::int64_t first_seq, std::int64_t last_seq);
  OutboxStats outbox_stats() const;
  // Queues scan `id` again: its sample, the scan and every stored point (re-ship). Returns
  // the rows added. Throws Error(not_found).
  std::size_t outbox_reship(std::int64_t scan_id, const std::string& actor);

  // ---- audit
  void audit(const std::string& actor, const std::string& action, const std::string& target,
             const nlohmann::json& detail = nlohmann::json::object());
  std::vector<AuditEvent> audit_events(std::size_t offset, std::size_t limit) const;

  // ---- tokens (hashes only)
  void put_token(const TokenEntry& t);
  bool delete_token(const std::string& name);
  std::vector<TokenEntry> tokens() const;

  // ---- retention (retention.cpp, store.retention_days)
  struct PruneResult {
    std::int64_t scans = 0;        // whose points were pruned
    std::int64_t points = 0;       // removed
    std::int64_t pages_freed = 0;  // returned to the file system by the incremental vacuum
  };
  // Removes the points of up to `max_scans` finished scans (completed, failed, cancelled)
  // that finished before `before` (UTC ISO-8601) and whose every point the central archive
  // has committed (archived_points), with nothing of them left in the outbox: never a point
  // the archive does not hold. The scan rows (counters, times, state), their fits and
  // verdicts, alerts and audit stay; the scan is marked points_pruned_at. One transaction
  // per scan, then the freed pages go back to the file system a step at a time, so the
  // writer is never held for long.
  PruneResult prune_archived(const std::string& before, std::size_t max_scans = 100);
  // When scan `id`'s points were pruned, if they were.
  std::optional<std::string> points_pruned_at(std::int64_t id) const;
  // Returns the store's free pages to the file system, `pages_per_step` per transaction.
  std::int64_t release_free_pages(int pages_per_step = 2048);

  // ---- backup and restore (backup.cpp)
  // What a copy of the store holds, and what making it cost.
  struct BackupInfo {
    std::uint64_t bytes = 0;
    int schema_version = 0;
    std::int64_t scans = 0;
    std::int64_t points = 0;   // stored (pruned ones not counted)
    double seconds = 0;        // backup_to: the copy's wall time
  };
  // A consistent copy of the store as it was when the call began, written to `dest` (which
  // must not exist) by SQLite's online backup API: `pages_per_step` pages per step, all from
  // one read snapshot held for the whole copy. In WAL mode a reader never blocks the writer,
  // so scans go on storing points meanwhile; the snapshot keeps the copy from restarting at
  // every commit, as the backup API does when its source changes between steps. The copy is
  // in rollback-journal mode: one self-contained file. Throws Error(io_error) naming `dest`.
  BackupInfo backup_to(const std::filesystem::path& dest, int pages_per_step = 1024) const;
  // Whether `file` is a store this goniod can open: an SQLite database whose integrity check
  // passes, with a gonio schema version (1..kSchemaVersion) and the gonio tables. Opens it
  // read-only. Throws Error(invalid_argument, field "file") naming the file and what is wrong.
  static BackupInfo inspect(const std::filesystem::path& file);
  // Restores the copy `file` as `state_dir`/goniod.db. `state_dir` must be absent or empty:
  // anything else is refused with Error(invalid_state, field "state_dir") naming it, as is a
  // file inspect() refuses, and nothing is written then. An older schema migrates at the
  // next open, as usual.
  static BackupInfo restore(const std::filesystem::path& file, const std::filesystem::path& state_dir);

  // ---- storage (storage.hpp)
  struct StorageState {
    std::filesystem::path dir;
    SpaceInfo space;
    bool writable = true;   // false from a storage failure until a write goes through again
    bool low = false;       // free space below store.min_free_mb
    std::string fault;      // the failure that made it read-only (empty while writable)
    std::uint64_t min_free_bytes = 0;
    bool reserve = false;   // the reserve file is in place
  };
  static constexpr std::uint64_t kReserveBytes = 1 << 20;
  StorageState storage() const;
  bool writable() const noexcept { return !read_only_.load(); }
  void set_min_free_mb(double mb);
  // While read-only and the space is back: one small write (an audit row), which makes the
  // store writable again when it goes through. Returns writable().
  bool probe();
  // Writes made on this thread while one lives may use the reserve (the pause of the
  // running scan and its storage alert) and do not make the store writable again.
  class Essential {
   public:
    Essential() noexcept;
    ~Essential();
    Essential(const Essential&) = delete;
    Essential& operator=(const Essential&) = delete;
  };

  struct Connection;  // a sqlite3 handle with its cached statements

 private:
  // Marks the store read-only (releasing the reserve at SQLITE_FULL) and returns the error
  // to throw. Called with the write lock held.
  Error storage_failure(int sqlite_code, std::string_view what, std::string_view message);
  // Before a write (write lock held): throws Error(storage_unavailable) while read-only and
  // the space is still short.
  void before_write();
  // After a write went through (write lock held): writable again.
  void after_commit();
  std::filesystem::path reserve_path() const;
  std::filesystem::path state_dir() const;  // absolute
  class ReadLease;
  ReadLease read() const;
  // WAL, the synchronous level asked for, foreign keys: each time the writer is opened.
  void configure_writer(Connection& c) const;
  void migrate();
  // auto_vacuum = INCREMENTAL on the file (schema 7), with the VACUUM an existing file needs.
  void incremental_vacuum_on();
  void outbox_in(OutboxRow::Kind kind, std::int64_t ref, std::int64_t idx,
                 const nlohmann::json& detail = nullptr);
  void outbox_written();

  std::filesystem::path path_;
  bool synchronous_full_;
  mutable std::mutex write_mu_;
  std::unique_ptr<Connection> writer_;
  mutable std::mutex pool_mu_;
  mutable std::vector<std::unique_ptr<Connection>> readers_;
  std::atomic<bool> outbox_on_{false};
  std::atomic<bool> read_only_{false};
  std::atomic<bool> immutable_reads_{false};  // a read-only file system at open
  mutable std::mutex space_mu_;
  std::string fault_;
  std::uint64_t min_free_bytes_ = 64ull << 20;
  std::mutex listener_mu_;
  std::function<void()> outbox_listener_;
};

}  // namespace gonio::daemon
