// Store — SQLite in WAL mode with versioned migrations (see store.hpp).
#include "gonio/daemon/store.hpp"

#include <sqlite3.h>

#include <algorithm>
#include <map>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/proto/error.hpp"

namespace gonio::daemon {

using nlohmann::json;

// ---- connection and statements ---------------------------------------------------------

struct Store::Connection {
  sqlite3* db = nullptr;
  std::map<std::string, sqlite3_stmt*, std::less<>> cache;
  Store* owner = nullptr;  // the writer's store: its storage failures make the store read-only

  Connection(const std::filesystem::path& file, int flags) {
    if (sqlite3_open_v2(file.c_str(), &db, flags | SQLITE_OPEN_NOMUTEX, nullptr) != SQLITE_OK) {
      const std::string msg = db ? sqlite3_errmsg(db) : "out of memory";
      sqlite3_close(db);
      throw Error(Errc::io_error, fmt::format("cannot open {}: {}", file.string(), msg));
    }
    sqlite3_busy_timeout(db, 5000);
    sqlite3_extended_result_codes(db, 1);
  }
  ~Connection() {
    for (auto& [sql, st] : cache) sqlite3_finalize(st);
    sqlite3_close(db);
  }
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  [[noreturn]] void fail(std::string_view what) const {
    const int rc = sqlite3_extended_errcode(db);
    if (owner && is_storage_failure(rc)) throw owner->storage_failure(rc, what, sqlite3_errmsg(db));
    throw Error(Errc::io_error, fmt::format("store: {}: {}", what, sqlite3_errmsg(db)));
  }
  void exec(const char* sql) {
    char* err = nullptr;
    const int rc = sqlite3_exec(db, sql, nullptr, nullptr, &err);
    if (rc != SQLITE_OK) {
      const std::string msg = err ? err : "unknown error";
      sqlite3_free(err);
      if (owner && is_storage_failure(sqlite3_extended_errcode(db)))
        throw owner->storage_failure(sqlite3_extended_errcode(db), sql, msg);
      throw Error(Errc::io_error, fmt::format("store: {}", msg));
    }
  }
  // Around every write of the writer connection (storage.hpp).
  void begin_write() {
    if (owner) owner->before_write();
  }
  void committed() {
    if (owner) owner->after_commit();
  }
  sqlite3_stmt* prepare(std::string_view sql) {
    if (const auto it = cache.find(sql); it != cache.end()) return it->second;
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v3(db, sql.data(), static_cast<int>(sql.size()), SQLITE_PREPARE_PERSISTENT,
                           &st, nullptr) != SQLITE_OK)
      fail(fmt::format("prepare '{}'", sql));
    cache.emplace(std::string(sql), st);
    return st;
  }
};

namespace {

using Connection = Store::Connection;

// A cached statement in use: binds by position (1-based), steps, resets when done.
class Stmt {
 public:
  Stmt(Connection& c, std::string_view sql) : c_(c), st_(c.prepare(sql)) {}
  ~Stmt() {
    sqlite3_reset(st_);
    sqlite3_clear_bindings(st_);
  }
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;

  Stmt& bind(int i, std::int64_t v) { return check(sqlite3_bind_int64(st_, i, v)); }
  Stmt& bind(int i, int v) { return check(sqlite3_bind_int64(st_, i, v)); }
  Stmt& bind(int i, std::size_t v) { return bind(i, static_cast<std::int64_t>(v)); }
  Stmt& bind(int i, double v) { return check(sqlite3_bind_double(st_, i, v)); }
  Stmt& bind(int i, bool v) { return bind(i, std::int64_t{v ? 1 : 0}); }
  Stmt& bind(int i, std::string_view v) {
    return check(sqlite3_bind_text(st_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
  }
  Stmt& bind(int i, const std::string& v) { return bind(i, std::string_view(v)); }
  Stmt& bind(int i, const char* v) { return bind(i, std::string_view(v)); }
  template <typename T>
  Stmt& bind(int i, const std::optional<T>& v) {
    if (!v) return check(sqlite3_bind_null(st_, i));
    return bind(i, *v);
  }
  // true while rows come
  bool step() {
    const int rc = sqlite3_step(st_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    if ((rc & 0xff) == SQLITE_CONSTRAINT)
      throw Error(Errc::invalid_state, fmt::format("store: {}", sqlite3_errmsg(c_.db)));
    c_.fail("step");
  }
  void run() {
    while (step()) {
    }
  }
  std::int64_t i64(int col) const { return sqlite3_column_int64(st_, col); }
  double f64(int col) const { return sqlite3_column_double(st_, col); }
  bool null(int col) const { return sqlite3_column_type(st_, col) == SQLITE_NULL; }
  std::string text(int col) const {
    const auto* p = sqlite3_column_text(st_, col);
    return p ? std::string(reinterpret_cast<const char*>(p),
                           static_cast<std::size_t>(sqlite3_column_bytes(st_, col)))
             : std::string();
  }
  std::optional<std::string> opt_text(int col) const {
    if (null(col)) return std::nullopt;
    return text(col);
  }
  std::optional<std::int64_t> opt_i64(int col) const {
    if (null(col)) return std::nullopt;
    return i64(col);
  }

 private:
  Stmt& check(int rc) {
    if (rc != SQLITE_OK) c_.fail("bind");
    return *this;
  }
  Connection& c_;
  sqlite3_stmt* st_;
};

// BEGIN IMMEDIATE … COMMIT, rolled back when left by an exception.
class Transaction {
 public:
  explicit Transaction(Connection& c) : c_(c) {
    c_.begin_write();
    c_.exec("BEGIN IMMEDIATE");
  }
  ~Transaction() {
    if (!done_) sqlite3_exec(c_.db, "ROLLBACK", nullptr, nullptr, nullptr);
  }
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void commit() {
    c_.exec("COMMIT");
    done_ = true;
    c_.committed();
  }

 private:
  Connection& c_;
  bool done_ = false;
};

// Migration k brings the schema from version k to k + 1. Never edit a released one.
constexpr const char* kMigrations[] = {
    // 0 -> 1: the five tables of docs/architecture.md §5.
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
};
static_assert(std::size(kMigrations) == Store::kSchemaVersion);

constexpr const char* kScanColumns =
    "id, sample_id, plan, state, reason, predicted, queue_pos, submitted_by, submitted_at, "
    "started_at, finished_at, points_total, points_done, points_diverged";

Scan read_scan(const Stmt& s) {
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

constexpr const char* kSampleColumns = "id, name, notes, bsdf, tolerance, created_at";

Sample read_sample(const Stmt& s) {
  Sample x;
  x.id = s.i64(0);
  x.spec.name = s.text(1);
  x.spec.notes = s.text(2);
  x.spec.bsdf = s.opt_text(3);
  x.spec.tolerance = s.f64(4);
  x.created_at = s.text(5);
  return x;
}

constexpr const char* kAlertColumns =
    "id, kind, severity, dedup_key, scan_id, sample_id, point_index, message, first_at, "
    "last_at, count, acknowledged, acknowledged_by, acknowledged_at";

Alert read_alert(const Stmt& s) {
  Alert a;
  a.id = s.i64(0);
  a.kind = s.text(1);
  a.severity = static_cast<Severity>(std::clamp<std::int64_t>(s.i64(2), 0, 2));
  a.dedup_key = s.text(3);
  a.scan_id = s.opt_i64(4);
  a.sample_id = s.opt_i64(5);
  a.point_index = s.opt_i64(6);
  a.message = s.text(7);
  a.first_at = s.text(8);
  a.last_at = s.text(9);
  a.count = s.i64(10);
  a.acknowledged = s.i64(11) != 0;
  a.acknowledged_by = s.text(12);
  a.acknowledged_at = s.opt_text(13);
  return a;
}

void audit_in(Connection& c, const std::string& actor, const std::string& action,
              const std::string& target, const json& detail) {
  Stmt(c, "INSERT INTO audit(at, actor, action, target, detail) VALUES (?, ?, ?, ?, ?)")
      .bind(1, utc::now())
      .bind(2, actor)
      .bind(3, action)
      .bind(4, target)
      .bind(5, detail.dump())
      .run();
}

// Waiting scans in queue order (ids).
std::vector<std::int64_t> waiting_ids(Connection& c) {
  Stmt s(c, "SELECT id FROM scans WHERE state IN ('queued','paused','interrupted') "
            "ORDER BY queue_pos, id");
  std::vector<std::int64_t> ids;
  while (s.step()) ids.push_back(s.i64(0));
  return ids;
}

void renumber(Connection& c, const std::vector<std::int64_t>& ids) {
  for (std::size_t i = 0; i < ids.size(); ++i)
    Stmt(c, "UPDATE scans SET queue_pos = ? WHERE id = ?").bind(1, i).bind(2, ids[i]).run();
}

}  // namespace

// A reader connection borrowed from the pool for one call.
class Store::ReadLease {
 public:
  ReadLease(const Store& s, std::unique_ptr<Connection> c) : s_(s), c_(std::move(c)) {}
  ~ReadLease() {
    if (!c_) return;
    std::lock_guard lock(s_.pool_mu_);
    if (s_.readers_.size() < 16) s_.readers_.push_back(std::move(c_));
  }
  ReadLease(ReadLease&&) = default;
  ReadLease& operator=(ReadLease&&) = delete;
  ReadLease(const ReadLease&) = delete;
  ReadLease& operator=(const ReadLease&) = delete;
  Connection& operator*() const { return *c_; }

 private:
  const Store& s_;
  std::unique_ptr<Connection> c_;
};

Store::ReadLease Store::read() const {
  {
    std::lock_guard lock(pool_mu_);
    if (!readers_.empty()) {
      auto c = std::move(readers_.back());
      readers_.pop_back();
      return ReadLease(*this, std::move(c));
    }
  }
  // On a read-only file system a WAL database without its -shm index cannot be opened as
  // usual; with no -wal either (goniod stopped cleanly) the file is complete and cannot
  // change, which is what SQLite's immutable mode is for.
  if (immutable_reads_) {
    auto c = std::make_unique<Connection>(
        std::filesystem::path("file:" + path_.string() + "?immutable=1"), SQLITE_OPEN_READONLY | SQLITE_OPEN_URI);
    return ReadLease(*this, std::move(c));
  }
  auto c = std::make_unique<Connection>(path_, SQLITE_OPEN_READONLY);
  return ReadLease(*this, std::move(c));
}

Store::Store(const std::filesystem::path& file, bool synchronous_full)
    : path_(file), synchronous_full_(synchronous_full) {
  writer_ = std::make_unique<Connection>(file, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  writer_->owner = this;
  try {
    writer_->exec("PRAGMA journal_mode = WAL");
    writer_->exec(synchronous_full_ ? "PRAGMA synchronous = FULL" : "PRAGMA synchronous = NORMAL");
    writer_->exec("PRAGMA foreign_keys = ON");
    migrate();
  } catch (const Error& e) {
    // A full disk at start: goniod serves what is stored, read-only (storage.hpp).
    if (e.code() != Errc::storage_unavailable) throw;
    spdlog::error("store: opened read-only: {}", e.what());
    std::error_code ec;
    if (space_of(state_dir()).read_only && !std::filesystem::exists(path_.string() + "-wal", ec))
      immutable_reads_ = true;
  }
  // A disk already full at start: read-only from the outset rather than at the first write
  // that happens not to fit in the pages SQLite has already allocated.
  const auto space = space_of(state_dir());
  if (writable() && space.known && (space.read_only || space.free_bytes < kReserveBytes)) {
    read_only_ = true;
    std::lock_guard lock(space_mu_);
    fault_ = fmt::format("the disk was full at start ({})", describe_space(state_dir(), space));
    spdlog::error("store: opened read-only: {}", fault_);
  }
  if (writable() && !std::filesystem::exists(reserve_path()) && !make_reserve(reserve_path(), kReserveBytes))
    spdlog::warn("store: cannot set {} MiB aside in {}: {}", kReserveBytes >> 20, reserve_path().string(),
                 describe_space(state_dir(), space_of(state_dir())));
}

// ---- storage ---------------------------------------------------------------------------

namespace {
thread_local int essential_depth = 0;
}  // namespace

Store::Essential::Essential() noexcept { ++essential_depth; }
Store::Essential::~Essential() { --essential_depth; }

std::filesystem::path Store::reserve_path() const { return path_.string() + "-reserve"; }

std::filesystem::path Store::state_dir() const {
  std::error_code ec;
  const auto abs = std::filesystem::absolute(path_, ec);
  return (ec ? path_ : abs).parent_path();
}

void Store::set_min_free_mb(double mb) {
  std::lock_guard lock(space_mu_);
  min_free_bytes_ = static_cast<std::uint64_t>(mb * (1 << 20));
}

Store::StorageState Store::storage() const {
  StorageState s;
  s.dir = state_dir();
  s.space = space_of(s.dir);
  {
    std::lock_guard lock(space_mu_);
    s.fault = fault_;
    s.min_free_bytes = min_free_bytes_;
  }
  s.writable = writable();
  s.low = s.space.known && (s.space.read_only || s.space.free_bytes < s.min_free_bytes);
  std::error_code ec;
  s.reserve = std::filesystem::exists(reserve_path(), ec);
  return s;
}

Error Store::storage_failure(int code, std::string_view what, std::string_view message) {
  const auto dir = state_dir();
  const auto space = space_of(dir);
  if ((code & 0xff) == SQLITE_FULL) {
    std::error_code ec;
    if (std::filesystem::remove(reserve_path(), ec))
      spdlog::warn("store: the disk is full; released the {} MiB reserve for the pause and its alert",
                   kReserveBytes >> 20);
  }
  const bool was_writable = !read_only_.exchange(true);
  {
    std::lock_guard lock(space_mu_);
    fault_ = fmt::format("{} ({})", message, describe_space(dir, space));
  }
  if (was_writable) spdlog::error("store: read-only from now on: {}: {}; {}", what, message, describe_space(dir, space));
  return Error(Errc::storage_unavailable,
               fmt::format("store: cannot write ({}): {}; reads go on, writes resume once space is back",
                           message, describe_space(dir, space)));
}

void Store::before_write() {
  if (!read_only_ || essential_depth > 0) return;
  const auto dir = state_dir();
  const auto space = space_of(dir);
  std::uint64_t need = 0;
  std::string fault;
  {
    std::lock_guard lock(space_mu_);
    need = min_free_bytes_ + kReserveBytes;
    fault = fault_;
  }
  // Enough room again: let the write try (and make the store writable if it goes through).
  if (space.known && !space.read_only && space.free_bytes >= need) return;
  throw Error(Errc::storage_unavailable,
              fmt::format("the store is read-only since a write failed ({}); now {}; writes resume "
                          "once {:.0f} MiB are free (store.min_free_mb and the reserve)",
                          fault, describe_space(dir, space), static_cast<double>(need) / (1 << 20)));
}

void Store::after_commit() {
  if (!read_only_ || essential_depth > 0) return;
  if (!std::filesystem::exists(reserve_path()) && !make_reserve(reserve_path(), kReserveBytes))
    spdlog::warn("store: cannot set the reserve aside again yet");
  read_only_ = false;
  {
    std::lock_guard lock(space_mu_);
    fault_.clear();
  }
  spdlog::info("store: writable again ({})", describe_space(state_dir(), space_of(state_dir())));
}

bool Store::probe() {
  if (writable()) return true;
  try {
    std::lock_guard lock(write_mu_);
    if (sqlite3_db_readonly(writer_->db, "main") == 1) {
      // Opened on a read-only file system: SQLite fell back to reading. Open it again for
      // writing once the file system allows it.
      before_write();
      auto w = std::make_unique<Connection>(path_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
      w->owner = this;
      w->exec("PRAGMA journal_mode = WAL");
      w->exec(synchronous_full_ ? "PRAGMA synchronous = FULL" : "PRAGMA synchronous = NORMAL");
      w->exec("PRAGMA foreign_keys = ON");
      writer_ = std::move(w);
      immutable_reads_ = false;
      std::lock_guard pool(pool_mu_);
      readers_.clear();
    }
    Transaction t(*writer_);
    audit_in(*writer_, "goniod", "store.writable", "", json::object());
    t.commit();
  } catch (const Error& e) {
    if (e.code() != Errc::storage_unavailable) throw;
  }
  return writable();
}

Store::~Store() = default;

int Store::schema_version() const {
  std::lock_guard lock(write_mu_);
  Stmt s(*writer_, "PRAGMA user_version");
  return s.step() ? static_cast<int>(s.i64(0)) : 0;
}

void Store::create_at_version(const std::filesystem::path& file, int version) {
  if (version < 0 || version > kSchemaVersion)
    throw Error::out_of_range("version", version, 0, kSchemaVersion);
  Connection c(file, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  for (int v = 0; v < version; ++v) {
    c.exec(kMigrations[v]);
    c.exec(fmt::format("PRAGMA user_version = {}", v + 1).c_str());
  }
}

void Store::migrate() {
  std::lock_guard lock(write_mu_);
  int version = 0;
  {
    Stmt s(*writer_, "PRAGMA user_version");
    if (s.step()) version = static_cast<int>(s.i64(0));
  }
  if (version > kSchemaVersion)
    throw Error(Errc::unsupported,
                fmt::format("{} has schema version {}, newer than this goniod understands ({}); "
                            "use a newer goniod",
                            path_.string(), version, kSchemaVersion));
  for (; version < kSchemaVersion; ++version) {
    Transaction t(*writer_);
    writer_->exec(kMigrations[version]);
    writer_->exec(fmt::format("PRAGMA user_version = {}", version + 1).c_str());
    audit_in(*writer_, "goniod", "store.migrate", "",
             json{{"from", version}, {"to", version + 1}});
    t.commit();
    spdlog::info("store: migrated {} to schema version {}", path_.string(), version + 1);
  }
}

// ---- samples ---------------------------------------------------------------------------

Sample Store::create_sample(const SampleSpec& spec, const std::string& actor) {
  spec.validate("");
  std::lock_guard lock(write_mu_);
  Transaction t(*writer_);
  {
    Stmt s(*writer_, "SELECT 1 FROM samples WHERE name = ?");
    s.bind(1, spec.name);
    if (s.step())
      throw Error::exists("name", fmt::format("a sample named '{}'", spec.name));
  }
  Sample out;
  out.spec = spec;
  out.created_at = utc::now();
  Stmt(*writer_, "INSERT INTO samples(name, notes, bsdf, tolerance, created_at) VALUES (?,?,?,?,?)")
      .bind(1, spec.name)
      .bind(2, spec.notes)
      .bind(3, spec.bsdf)
      .bind(4, spec.tolerance)
      .bind(5, out.created_at)
      .run();
  out.id = sqlite3_last_insert_rowid(writer_->db);
  audit_in(*writer_, actor, "sample.create", fmt::format("sample:{}", out.id), json(spec));
  outbox_in(OutboxRow::Kind::sample, out.id, 0);
  t.commit();
  outbox_written();
  return out;
}

std::optional<Sample> Store::sample(std::int64_t id) const {
  auto c = read();
  Stmt s(*c, fmt::format("SELECT {} FROM samples WHERE id = ?", kSampleColumns));
  s.bind(1, id);
  if (!s.step()) return std::nullopt;
  return read_sample(s);
}

std::optional<Sample> Store::sample_by_name(const std::string& name) const {
  auto c = read();
  Stmt s(*c, fmt::format("SELECT {} FROM samples WHERE name = ?", kSampleColumns));
  s.bind(1, name);
  if (!s.step()) return std::nullopt;
  return read_sample(s);
}

std::vector<Sample> Store::samples(std::size_t offset, std::size_t limit) const {
  auto c = read();
  Stmt s(*c, fmt::format("SELECT {} FROM samples ORDER BY id LIMIT ? OFFSET ?", kSampleColumns));
  s.bind(1, limit).bind(2, offset);
  std::vector<Sample> out;
  while (s.step()) out.push_back(read_sample(s));
  return out;
}

// ---- scans -----------------------------------------------------------------------------

Scan Store::insert_scan(const ScanPlan& plan, bool predicted, const std::string& actor) {
  std::lock_guard lock(write_mu_);
  Transaction t(*writer_);
  // Insert after every waiting scan of the same or a higher priority.
  std::vector<std::int64_t> ids;
  std::size_t insert_at = 0;
  {
    Stmt s(*writer_, "SELECT id, priority FROM scans WHERE state IN ('queued','paused',"
                     "'interrupted') ORDER BY queue_pos, id");
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
  json stored = plan;
  Stmt(*writer_, "INSERT INTO scans(sample_id, plan, state, predicted, priority, queue_pos, "
                 "not_before, submitted_by, submitted_at, points_total) "
                 "VALUES (?, ?, 'queued', ?, ?, 0, ?, ?, ?, ?)")
      .bind(1, plan.sample_id)
      .bind(2, stored.dump())
      .bind(3, predicted)
      .bind(4, plan.priority)
      .bind(5, plan.not_before)
      .bind(6, actor)
      .bind(7, sc.submitted_at)
      .bind(8, sc.points_total)
      .run();
  sc.id = sqlite3_last_insert_rowid(writer_->db);
  ids.insert(ids.begin() + static_cast<std::ptrdiff_t>(insert_at), sc.id);
  renumber(*writer_, ids);
  sc.queue_position = static_cast<std::int64_t>(insert_at);
  audit_in(*writer_, actor, "scan.submit", fmt::format("scan:{}", sc.id),
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
  Stmt s(*c, fmt::format("SELECT {} FROM scans WHERE id = ?", kScanColumns));
  s.bind(1, id);
  if (!s.step()) return std::nullopt;
  return read_scan(s);
}

std::optional<std::pair<std::size_t, std::size_t>> Store::scan_progress(std::int64_t id) const {
  auto c = read();
  Stmt s(*c, "SELECT points_done, points_total FROM scans WHERE id = ?");
  s.bind(1, id);
  if (!s.step()) return std::nullopt;
  return std::make_pair(static_cast<std::size_t>(s.i64(0)), static_cast<std::size_t>(s.i64(1)));
}

std::vector<Scan> Store::scans(const ScanFilter& f) const {
  auto c = read();
  Stmt s(*c, fmt::format("SELECT {} FROM scans WHERE (?1 IS NULL OR state = ?1) AND "
                         "(?2 IS NULL OR sample_id = ?2) AND (?5 IS NULL OR submitted_at >= ?5) AND "
                         "(?6 IS NULL OR submitted_at < ?6) AND (?7 IS NULL OR "
                         "instr(lower(coalesce(json_extract(plan, '$.name'), '')), lower(?7)) > 0) "
                         "ORDER BY id DESC LIMIT ?3 OFFSET ?4",
                         kScanColumns));
  if (f.state) s.bind(1, std::string(to_text(*f.state)));
  s.bind(2, f.sample_id).bind(3, f.limit).bind(4, f.offset);
  s.bind(5, f.since).bind(6, f.until).bind(7, f.text);
  std::vector<Scan> out;
  while (s.step()) out.push_back(read_scan(s));
  return out;
}

std::vector<Scan> Store::queue() const {
  auto c = read();
  Stmt s(*c, fmt::format("SELECT {} FROM scans WHERE state IN ('queued','paused','interrupted') "
                         "ORDER BY queue_pos, id",
                         kScanColumns));
  std::vector<Scan> out;
  while (s.step()) out.push_back(read_scan(s));
  return out;
}

std::optional<Scan> Store::next_runnable(const std::string& now_iso,
                                         std::optional<std::string>* earliest) const {
  auto c = read();
  {
    Stmt s(*c, fmt::format("SELECT {} FROM scans WHERE state = 'interrupted' "
                           "ORDER BY queue_pos, id LIMIT 1",
                           kScanColumns));
    if (s.step()) return read_scan(s);
  }
  {
    // ISO-8601 UTC strings of one format compare like the times they name.
    Stmt s(*c, fmt::format("SELECT {} FROM scans WHERE state = 'queued' AND "
                           "(not_before IS NULL OR not_before <= ?) ORDER BY queue_pos, id LIMIT 1",
                           kScanColumns));
    s.bind(1, now_iso);
    if (s.step()) return read_scan(s);
  }
  if (earliest) {
    Stmt s(*c, "SELECT MIN(not_before) FROM scans WHERE state = 'queued' AND not_before > ?");
    s.bind(1, now_iso);
    *earliest = s.step() ? s.opt_text(0) : std::nullopt;
  }
  return std::nullopt;
}

void Store::set_scan_state(std::int64_t id, ScanState state, const std::string& reason,
                           const std::string& actor) {
  std::lock_guard lock(write_mu_);
  Transaction t(*writer_);
  std::string old;
  {
    Stmt s(*writer_, "SELECT state FROM scans WHERE id = ?");
    s.bind(1, id);
    if (!s.step()) throw Error::not_found("scan", fmt::format("scan {}", id));
    old = s.text(0);
  }
  const auto now = utc::now();
  Stmt(*writer_, "UPDATE scans SET state = ?1, reason = ?2, "
                 "started_at = CASE WHEN ?1 = 'running' AND started_at IS NULL THEN ?3 "
                 "ELSE started_at END, "
                 "finished_at = CASE WHEN ?1 IN ('completed','failed','cancelled') THEN ?3 "
                 "ELSE finished_at END WHERE id = ?4")
      .bind(1, std::string(to_text(state)))
      .bind(2, reason)
      .bind(3, now)
      .bind(4, id)
      .run();
  audit_in(*writer_, actor, "scan.state", fmt::format("scan:{}", id),
           json{{"from", old}, {"to", to_text(state)}, {"reason", reason}});
  outbox_in(OutboxRow::Kind::scan, id, 0, json{{"state", to_text(state)}, {"reason", reason}});
  t.commit();
  outbox_written();
}

void Store::reorder(std::int64_t id, std::size_t position, const std::string& actor) {
  std::lock_guard lock(write_mu_);
  Transaction t(*writer_);
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
  audit_in(*writer_, actor, "queue.reorder", fmt::format("scan:{}", id),
           json{{"position", position}});
  t.commit();
}

std::vector<std::int64_t> Store::recover_running(const std::string& reason) {
  std::lock_guard lock(write_mu_);
  Transaction t(*writer_);
  std::vector<std::int64_t> ids;
  {
    Stmt s(*writer_, "SELECT id FROM scans WHERE state = 'running'");
    while (s.step()) ids.push_back(s.i64(0));
  }
  for (auto id : ids) {
    Stmt(*writer_, "UPDATE scans SET state = 'interrupted', reason = ? WHERE id = ?")
        .bind(1, reason)
        .bind(2, id)
        .run();
    audit_in(*writer_, "goniod", "scan.state", fmt::format("scan:{}", id),
             json{{"from", "running"}, {"to", "interrupted"}, {"reason", reason}});
    outbox_in(OutboxRow::Kind::scan, id, 0, json{{"state", "interrupted"}, {"reason", reason}});
  }
  t.commit();
  if (!ids.empty()) outbox_written();
  return ids;
}

// ---- points ----------------------------------------------------------------------------

void Store::insert_point(const PointRecord& p) { insert_point(p, json(p).dump()); }

void Store::insert_point(const PointRecord& p, const std::string& data) {
  std::lock_guard lock(write_mu_);
  Transaction t(*writer_);
  try {
    Stmt(*writer_, "INSERT INTO points(scan_id, idx, geometry_index, diverged, finished_at, data) "
                   "VALUES (?, ?, ?, ?, ?, ?)")
        .bind(1, p.scan_id)
        .bind(2, p.index)
        .bind(3, p.geometry_index)
        .bind(4, p.diverged)
        .bind(5, p.finished_at)
        .bind(6, data)
        .run();
  } catch (const Error& e) {
    if (e.code() == Errc::invalid_state)
      throw Error::exists("index", fmt::format("point {} of scan {}", p.index, p.scan_id));
    throw;
  }
  Stmt(*writer_, "UPDATE scans SET points_done = points_done + 1, "
                 "points_diverged = points_diverged + ? WHERE id = ?")
      .bind(1, std::int64_t{p.diverged ? 1 : 0})
      .bind(2, p.scan_id)
      .run();
  outbox_in(OutboxRow::Kind::point, p.scan_id, p.index);
  t.commit();
  outbox_written();
}

std::vector<std::string> Store::point_json(std::int64_t scan_id, std::size_t offset,
                                           std::size_t limit) const {
  auto c = read();
  Stmt s(*c, "SELECT data FROM points WHERE scan_id = ? AND idx >= ? ORDER BY idx LIMIT ?");
  // Points are stored in order from 0, so index >= offset is the page (and uses the key).
  s.bind(1, scan_id).bind(2, offset).bind(3, limit);
  std::vector<std::string> out;
  while (s.step()) out.push_back(s.text(0));
  return out;
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
  Stmt s(*c, "SELECT COUNT(*) FROM points WHERE scan_id = ?");
  s.bind(1, scan_id);
  return s.step() ? static_cast<std::size_t>(s.i64(0)) : 0;
}

std::int64_t Store::next_point_index(std::int64_t scan_id) const {
  auto c = read();
  Stmt s(*c, "SELECT COALESCE(MAX(idx) + 1, 0) FROM points WHERE scan_id = ?");
  s.bind(1, scan_id);
  return s.step() ? s.i64(0) : 0;
}

// ---- alerts ----------------------------------------------------------------------------

Alert Store::raise_alert(const AlertDraft& d, bool* created) {
  std::lock_guard lock(write_mu_);
  Transaction t(*writer_);
  const auto now = utc::now();
  std::optional<std::int64_t> open;
  {
    Stmt s(*writer_, "SELECT id FROM alerts WHERE dedup_key = ? AND acknowledged = 0 "
                     "ORDER BY id DESC LIMIT 1");
    s.bind(1, d.dedup_key);
    if (s.step()) open = s.i64(0);
  }
  std::int64_t id = 0;
  if (open) {
    id = *open;
    Stmt(*writer_, "UPDATE alerts SET count = count + 1, last_at = ?, message = ?, "
                   "severity = MAX(severity, ?), point_index = COALESCE(?, point_index) "
                   "WHERE id = ?")
        .bind(1, now)
        .bind(2, d.message)
        .bind(3, static_cast<std::int64_t>(d.severity))
        .bind(4, d.point_index)
        .bind(5, id)
        .run();
  } else {
    Stmt(*writer_, "INSERT INTO alerts(kind, severity, dedup_key, scan_id, sample_id, "
                   "point_index, message, first_at, last_at) VALUES (?,?,?,?,?,?,?,?,?)")
        .bind(1, d.kind)
        .bind(2, static_cast<std::int64_t>(d.severity))
        .bind(3, d.dedup_key)
        .bind(4, d.scan_id)
        .bind(5, d.sample_id)
        .bind(6, d.point_index)
        .bind(7, d.message)
        .bind(8, now)
        .bind(9, now)
        .run();
    id = sqlite3_last_insert_rowid(writer_->db);
  }
  Alert a;
  {
    Stmt s(*writer_, fmt::format("SELECT {} FROM alerts WHERE id = ?", kAlertColumns));
    s.bind(1, id);
    s.step();
    a = read_alert(s);
  }
  outbox_in(OutboxRow::Kind::alert, id, 0);
  t.commit();
  outbox_written();
  if (created) *created = !open;
  return a;
}

std::optional<Alert> Store::alert(std::int64_t id) const {
  auto c = read();
  Stmt s(*c, fmt::format("SELECT {} FROM alerts WHERE id = ?", kAlertColumns));
  s.bind(1, id);
  if (!s.step()) return std::nullopt;
  return read_alert(s);
}

std::vector<Alert> Store::alerts(const AlertFilter& f) const {
  auto c = read();
  Stmt s(*c, fmt::format("SELECT {} FROM alerts WHERE (?1 IS NULL OR acknowledged = ?1) AND "
                         "(?2 IS NULL OR scan_id = ?2) AND severity >= ?3 "
                         "ORDER BY id DESC LIMIT ?4 OFFSET ?5",
                         kAlertColumns));
  if (f.acknowledged) s.bind(1, *f.acknowledged);
  s.bind(2, f.scan_id)
      .bind(3, static_cast<std::int64_t>(f.min_severity.value_or(Severity::info)))
      .bind(4, f.limit)
      .bind(5, f.offset);
  std::vector<Alert> out;
  while (s.step()) out.push_back(read_alert(s));
  return out;
}

Alert Store::ack_alert(std::int64_t id, const std::string& actor) {
  {
    std::lock_guard lock(write_mu_);
    Transaction t(*writer_);
    {
      Stmt s(*writer_, "SELECT acknowledged FROM alerts WHERE id = ?");
      s.bind(1, id);
      if (!s.step())
        throw Error::not_found("alert", fmt::format("alert {}", id));
      if (s.i64(0) != 0) {
        t.commit();
        return *alert(id);
      }
    }
    Stmt(*writer_, "UPDATE alerts SET acknowledged = 1, acknowledged_by = ?, acknowledged_at = ? "
                   "WHERE id = ?")
        .bind(1, actor)
        .bind(2, utc::now())
        .bind(3, id)
        .run();
    audit_in(*writer_, actor, "alert.ack", fmt::format("alert:{}", id), json::object());
    outbox_in(OutboxRow::Kind::alert, id, 0);
    t.commit();
    outbox_written();
  }
  return *alert(id);
}

Alert Store::set_alert_message(std::int64_t id, const std::string& message) {
  {
    std::lock_guard lock(write_mu_);
    Transaction t(*writer_);
    Stmt s(*writer_, "UPDATE alerts SET message = ? WHERE id = ?");
    s.bind(1, message).bind(2, id).run();
    if (sqlite3_changes(writer_->db) == 0) throw Error::not_found("alert", fmt::format("alert {}", id));
    outbox_in(OutboxRow::Kind::alert, id, 0);
    t.commit();
    outbox_written();
  }
  return *alert(id);
}

// ---- archive outbox --------------------------------------------------------------------

// With the write lock held, inside the caller's transaction.
void Store::outbox_in(OutboxRow::Kind kind, std::int64_t ref, std::int64_t idx,
                      const json& detail) {
  if (!outbox_on_.load(std::memory_order_relaxed)) return;
  Stmt(*writer_, "INSERT INTO outbox(kind, ref, idx, at, detail) VALUES (?, ?, ?, ?, ?)")
      .bind(1, std::string(to_text(kind)))
      .bind(2, ref)
      .bind(3, idx)
      .bind(4, utc::now())
      .bind(5, detail.is_null() ? std::optional<std::string>() : std::optional(detail.dump()))
      .run();
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
  Stmt s(*c, "SELECT o.seq, o.kind, o.ref, o.idx, o.at, o.detail, p.data FROM outbox o "
             "LEFT JOIN points p ON o.kind = 'point' AND p.scan_id = o.ref AND p.idx = o.idx "
             "WHERE o.seq > ? ORDER BY o.seq LIMIT ?");
  s.bind(1, after);
  s.bind(2, limit);
  std::vector<OutboxRow> out;
  out.reserve(std::min<std::size_t>(limit, 4096));
  while (s.step()) {
    OutboxRow r;
    r.seq = s.i64(0);
    r.kind = parse_enum<OutboxRow::Kind>(s.text(1), "outbox.kind");
    r.ref = s.i64(2);
    r.idx = s.i64(3);
    r.at = s.text(4);
    if (const auto d = s.opt_text(5)) r.detail = json::parse(*d, nullptr, false);
    if (r.kind == OutboxRow::Kind::point) r.point_json = s.text(6);
    out.push_back(std::move(r));
  }
  return out;
}

void Store::outbox_remove(std::int64_t first_seq, std::int64_t last_seq) {
  std::lock_guard lock(write_mu_);
  writer_->begin_write();
  Stmt(*writer_, "DELETE FROM outbox WHERE seq BETWEEN ? AND ?").bind(1, first_seq).bind(2, last_seq).run();
}

OutboxStats Store::outbox_stats() const {
  auto c = read();
  OutboxStats st;
  // seq order is write order, so the first row is the oldest; MAX - MIN would overcount
  // after a partial removal, COUNT(*) is exact and the outbox stays small when shipping.
  Stmt s(*c, "SELECT COUNT(*), (SELECT at FROM outbox ORDER BY seq LIMIT 1) FROM outbox");
  if (s.step()) {
    st.rows = s.i64(0);
    st.oldest_at = s.opt_text(1);
  }
  return st;
}

std::size_t Store::outbox_reship(std::int64_t scan_id, const std::string& actor) {
  std::size_t added = 0;
  {
    std::lock_guard lock(write_mu_);
    Transaction t(*writer_);
    std::int64_t sample_id = 0;
    {
      Stmt s(*writer_, "SELECT sample_id FROM scans WHERE id = ?");
      s.bind(1, scan_id);
      if (!s.step()) throw Error::not_found("scan", fmt::format("scan {}", scan_id));
      sample_id = s.i64(0);
    }
    const auto now = utc::now();
    Stmt(*writer_, "INSERT INTO outbox(kind, ref, idx, at) VALUES ('sample', ?, 0, ?), "
                   "('scan', ?, 0, ?)")
        .bind(1, sample_id)
        .bind(2, now)
        .bind(3, scan_id)
        .bind(4, now)
        .run();
    Stmt(*writer_, "INSERT INTO outbox(kind, ref, idx, at) SELECT 'point', scan_id, idx, ? "
                   "FROM points WHERE scan_id = ? ORDER BY idx")
        .bind(1, now)
        .bind(2, scan_id)
        .run();
    added = 2 + static_cast<std::size_t>(sqlite3_changes(writer_->db));
    audit_in(*writer_, actor, "archive.reship", fmt::format("scan:{}", scan_id),
             json{{"rows", added}});
    t.commit();
  }
  std::lock_guard lock(listener_mu_);
  if (outbox_listener_) outbox_listener_();
  return added;
}

// ---- audit -----------------------------------------------------------------------------

void Store::audit(const std::string& actor, const std::string& action, const std::string& target,
                  const json& detail) {
  std::lock_guard lock(write_mu_);
  writer_->begin_write();
  audit_in(*writer_, actor, action, target, detail);
  writer_->committed();
}

std::vector<AuditEvent> Store::audit_events(std::size_t offset, std::size_t limit) const {
  auto c = read();
  Stmt s(*c, "SELECT id, at, actor, action, target, detail FROM audit ORDER BY id DESC "
             "LIMIT ? OFFSET ?");
  s.bind(1, limit).bind(2, offset);
  std::vector<AuditEvent> out;
  while (s.step()) {
    AuditEvent e;
    e.id = s.i64(0);
    e.at = s.text(1);
    e.actor = s.text(2);
    e.action = s.text(3);
    e.target = s.text(4);
    e.detail = json::parse(s.text(5), nullptr, false);
    out.push_back(std::move(e));
  }
  return out;
}

// ---- tokens ----------------------------------------------------------------------------

// ---- fits and profiles -----------------------------------------------------------------

namespace {

constexpr const char* kFitColumns = "id, scan_id, kind, model, created_by, created_at, result";

StoredFit read_fit(const Stmt& s) {
  StoredFit f;
  f.id = s.i64(0);
  f.scan_id = s.i64(1);
  f.kind = s.text(2);
  f.model = s.text(3);
  f.created_by = s.text(4);
  f.created_at = s.text(5);
  try {
    f.result = json::parse(s.text(6));
  } catch (const std::exception& e) {
    throw Error(Errc::internal, fmt::format("store: fit {} is unreadable: {}", f.id, e.what()));
  }
  return f;
}

constexpr const char* kProfileColumns =
    "version, name, scan_id, fit_id, created_by, created_at, profile";

StoredProfile read_profile(const Stmt& s) {
  StoredProfile p;
  p.version = s.i64(0);
  p.name = s.text(1);
  p.scan_id = s.opt_i64(2);
  p.fit_id = s.opt_i64(3);
  p.created_by = s.text(4);
  p.created_at = s.text(5);
  try {
    p.profile = json::parse(s.text(6));
  } catch (const std::exception& e) {
    throw Error(Errc::internal,
                fmt::format("store: profile version {} is unreadable: {}", p.version, e.what()));
  }
  return p;
}

}  // namespace

StoredFit Store::insert_fit(std::int64_t scan_id, const std::string& kind, const std::string& model,
                            const nlohmann::json& result, const std::string& actor) {
  StoredFit f;
  f.scan_id = scan_id;
  f.kind = kind;
  f.model = model;
  f.created_by = actor;
  f.created_at = utc::now();
  f.result = result;
  std::lock_guard lock(write_mu_);
  Transaction tx(*writer_);
  Stmt(*writer_, "INSERT INTO fits(scan_id, kind, model, created_by, created_at, result) "
                 "VALUES (?, ?, ?, ?, ?, ?)")
      .bind(1, scan_id)
      .bind(2, kind)
      .bind(3, model)
      .bind(4, actor)
      .bind(5, f.created_at)
      .bind(6, result.dump())
      .run();
  f.id = sqlite3_last_insert_rowid(writer_->db);
  const char* action = kind == "calibrate"   ? "instrument.calibrate"
                       : kind == "diagnosis" ? "divergence.diagnose"
                       : kind == "verdict"   ? "scan.verdict"
                                             : "scan.fit";
  audit_in(*writer_, actor, action,
           fmt::format("scan:{}", scan_id), json{{"fit", f.id}, {"model", model}});
  tx.commit();
  return f;
}

std::vector<StoredFit> Store::fits(std::int64_t scan_id, std::size_t limit) const {
  auto c = read();
  Stmt s(*c, fmt::format("SELECT {} FROM fits WHERE scan_id = ? AND kind <> 'verdict' "
                         "ORDER BY id DESC LIMIT ?",
                         kFitColumns));
  s.bind(1, scan_id).bind(2, limit);
  std::vector<StoredFit> out;
  while (s.step()) out.push_back(read_fit(s));
  return out;
}

std::optional<StoredFit> Store::latest_fit(std::int64_t scan_id, const std::string& kind) const {
  auto c = read();
  Stmt s(*c, fmt::format("SELECT {} FROM fits WHERE scan_id = ? AND kind = ? ORDER BY id DESC LIMIT 1",
                         kFitColumns));
  s.bind(1, scan_id).bind(2, kind);
  if (!s.step()) return std::nullopt;
  return read_fit(s);
}

StoredProfile Store::insert_profile(const std::string& name, const nlohmann::json& profile,
                                    std::optional<std::int64_t> scan_id,
                                    std::optional<std::int64_t> fit_id, const std::string& actor) {
  StoredProfile p;
  p.name = name;
  p.scan_id = scan_id;
  p.fit_id = fit_id;
  p.created_by = actor;
  p.created_at = utc::now();
  p.profile = profile;
  std::lock_guard lock(write_mu_);
  Transaction tx(*writer_);
  {
    Stmt s(*writer_, "SELECT COALESCE(MAX(version), 0) FROM profiles");
    p.version = s.step() ? s.i64(0) + 1 : 1;
  }
  Stmt(*writer_, "INSERT INTO profiles(version, name, scan_id, fit_id, created_by, created_at, "
                 "profile) VALUES (?, ?, ?, ?, ?, ?, ?)")
      .bind(1, p.version)
      .bind(2, name)
      .bind(3, scan_id)
      .bind(4, fit_id)
      .bind(5, actor)
      .bind(6, p.created_at)
      .bind(7, profile.dump())
      .run();
  audit_in(*writer_, actor, "profile.create", fmt::format("profile:{}", p.version),
           json{{"name", name}, {"scan", scan_id ? json(*scan_id) : json(nullptr)}});
  tx.commit();
  return p;
}

std::optional<StoredProfile> Store::latest_profile() const {
  auto c = read();
  Stmt s(*c, fmt::format("SELECT {} FROM profiles ORDER BY version DESC LIMIT 1",
                         kProfileColumns));
  if (!s.step()) return std::nullopt;
  return read_profile(s);
}

void Store::put_token(const TokenEntry& t) {
  std::lock_guard lock(write_mu_);
  Transaction tx(*writer_);
  Stmt(*writer_, "INSERT INTO tokens(name, role, sha256, created_at) VALUES (?, ?, ?, ?) "
                 "ON CONFLICT(name) DO UPDATE SET role = excluded.role, sha256 = excluded.sha256, "
                 "created_at = excluded.created_at")
      .bind(1, t.name)
      .bind(2, std::string(to_text(t.role)))
      .bind(3, t.sha256)
      .bind(4, utc::now())
      .run();
  audit_in(*writer_, "goniod", "auth.token", fmt::format("token:{}", t.name),
           json{{"role", to_text(t.role)}});
  tx.commit();
}

bool Store::delete_token(const std::string& name) {
  std::lock_guard lock(write_mu_);
  writer_->begin_write();
  Stmt s(*writer_, "DELETE FROM tokens WHERE name = ?");
  s.bind(1, name).run();
  return sqlite3_changes(writer_->db) > 0;
}

std::vector<TokenEntry> Store::tokens() const {
  auto c = read();
  Stmt s(*c, "SELECT name, role, sha256 FROM tokens ORDER BY name");
  std::vector<TokenEntry> out;
  while (s.step()) out.push_back(TokenEntry{s.text(0), parse_role(s.text(1)), s.text(2)});
  return out;
}

}  // namespace gonio::daemon
