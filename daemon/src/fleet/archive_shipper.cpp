// The archive shipper thread (see archive.hpp, docs/architecture.md §11).
#include <libpq-fe.h>

#include <algorithm>
#include <future>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/fleet/archive.hpp"
#include "gonio/daemon/instrument/alerts.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/version.hpp"

namespace gonio::daemon {

using nlohmann::json;
using namespace std::chrono_literals;

struct ArchiveShipper::Pg {
  PGconn* conn = nullptr;
  ~Pg() {
    if (conn) PQfinish(conn);
  }
  [[noreturn]] void fail(std::string_view what) const {
    std::string msg = conn ? PQerrorMessage(conn) : "no connection";
    while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
    // libpq's hints come on lines of their own; status and logs want one line.
    for (std::size_t at; (at = msg.find("\n\t")) != std::string::npos;) msg.replace(at, 2, "; ");
    for (char& c : msg)
      if (c == '\n' || c == '\t') c = ' ';
    throw Error(Errc::disconnected, fmt::format("archive: {}: {}", what, msg));
  }
  // Runs `sql` with text parameters; throws with the server's message on failure.
  void exec(const std::string& sql, const std::vector<std::optional<std::string>>& params = {},
            std::string_view what = {}) {
    std::vector<const char*> values;
    values.reserve(params.size());
    for (const auto& v : params) values.push_back(v ? v->c_str() : nullptr);
    PGresult* r = PQexecParams(conn, sql.c_str(), static_cast<int>(values.size()), nullptr,
                               values.data(), nullptr, nullptr, 0);
    const auto st = PQresultStatus(r);
    if (st != PGRES_COMMAND_OK && st != PGRES_TUPLES_OK) {
      std::string msg = PQresultErrorMessage(r);
      PQclear(r);
      while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
      throw Error(PQstatus(conn) == CONNECTION_OK ? Errc::io_error : Errc::disconnected,
                  fmt::format("archive: {}: {}", what.empty() ? std::string_view("query") : what, msg));
    }
    PQclear(r);
  }
  // Several statements in one text (a migration): the simple query protocol, no parameters.
  void exec_script(const std::string& sql, std::string_view what) {
    PGresult* r = PQexec(conn, sql.c_str());
    const auto st = PQresultStatus(r);
    if (st != PGRES_COMMAND_OK && st != PGRES_TUPLES_OK) {
      std::string msg = PQresultErrorMessage(r);
      PQclear(r);
      while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
      throw Error(Errc::io_error, fmt::format("archive: {}: {}", what, msg));
    }
    PQclear(r);
  }
  std::optional<std::string> scalar(const std::string& sql) {
    PGresult* r = PQexec(conn, sql.c_str());
    if (PQresultStatus(r) != PGRES_TUPLES_OK) {
      PQclear(r);
      fail(sql);
    }
    std::optional<std::string> out;
    if (PQntuples(r) > 0 && !PQgetisnull(r, 0, 0)) out = PQgetvalue(r, 0, 0);
    PQclear(r);
    return out;
  }
};

ArchiveShipper::ArchiveShipper(const Config::Archive& config, std::string instrument, Store& store,
                               AlertService* alerts)
    : config_(config), instrument_(std::move(instrument)), store_(store), alerts_(alerts),
      pg_(std::make_unique<Pg>()) {
  store_.set_outbox(true);
  store_.set_outbox_listener([this] { wake(); });
}

ArchiveShipper::~ArchiveShipper() {
  stop();
  store_.set_outbox_listener(nullptr);
}

void ArchiveShipper::start() {
  refresh_stats();
  thread_ = std::thread([this] { run(); });
}

void ArchiveShipper::stop() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void ArchiveShipper::wake() noexcept {
  // No lock: this runs inside the store's write lock. A missed wake-up costs one poll period.
  pending_.store(true, std::memory_order_release);
  cv_.notify_one();
}

bool ArchiveShipper::connect() {
  disconnect();
  // A connection string without connect_timeout gets 10 s: an unreachable server must not
  // hold the shipper (and goniod's shutdown) for the kernel's TCP timeout. Keywords before
  // the expanded string are overridden by it.
  const char* keys[] = {"connect_timeout", "application_name", "dbname", nullptr};
  const char* values[] = {"10", "goniod", config_.postgres.c_str(), nullptr};
  pg_->conn = PQconnectdbParams(keys, values, 1);
  if (PQstatus(pg_->conn) != CONNECTION_OK) pg_->fail("connect");
  pg_->exec("SET client_min_messages = warning", {}, "session");
  const int version = migrate();
  std::lock_guard lock(mu_);
  connected_ = true;
  schema_version_ = version;
  last_error_.clear();
  return true;
}

int ArchiveShipper::migrate() {
  auto& pg = *pg_;
  pg.exec("BEGIN", {}, "begin");
  try {
    // One goniod at a time creates or migrates; the others wait here, then find it done.
    pg.exec("SELECT pg_advisory_xact_lock(7364019283746501)", {}, "schema lock");
    pg.exec("CREATE TABLE IF NOT EXISTS gonio_archive_schema (version integer NOT NULL, "
            "migrated_at timestamptz NOT NULL DEFAULT now())", {}, "schema table");
    const auto v = pg.scalar("SELECT max(version) FROM gonio_archive_schema");
    int version = v ? std::stoi(*v) : 0;
    if (version > kArchiveSchemaVersion)
      throw Error(Errc::unsupported,
                  fmt::format("archive: the archive has schema version {}, newer than this goniod "
                              "understands ({}); use a newer goniod", version, kArchiveSchemaVersion));
    const auto& m = archive_migrations();
    for (; version < kArchiveSchemaVersion; ++version) {
      pg.exec_script(m[static_cast<std::size_t>(version)], fmt::format("migration to version {}", version + 1));
      pg.exec("INSERT INTO gonio_archive_schema (version) VALUES ($1)", {std::to_string(version + 1)},
              "schema version");
      spdlog::info("archive: migrated the archive to schema version {}", version + 1);
    }
    pg.exec("COMMIT", {}, "commit");
    return version;
  } catch (...) {
    PQclear(PQexec(pg.conn, "ROLLBACK"));  // best effort; the connection may be gone
    throw;
  }
}

void ArchiveShipper::disconnect() {
  drop_ahead();
  if (pg_->conn) PQfinish(pg_->conn);
  pg_->conn = nullptr;
  std::lock_guard lock(mu_);
  connected_ = false;
}

ArchiveShipper::Prepared ArchiveShipper::prepare(std::int64_t after) const {
  ArchiveInput in;
  in.rows = store_.outbox_batch(config_.batch, after);
  Prepared p;
  if (in.rows.empty()) return p;
  for (const auto& r : in.rows) {
    switch (r.kind) {
      case OutboxRow::Kind::sample:
        if (!in.samples.contains(r.ref))
          if (auto s = store_.sample(r.ref)) in.samples.emplace(r.ref, std::move(*s));
        break;
      case OutboxRow::Kind::scan:
      case OutboxRow::Kind::point:
        if (!in.scans.contains(r.ref))
          if (auto s = store_.scan(r.ref)) in.scans.emplace(r.ref, std::move(*s));
        break;
      case OutboxRow::Kind::alert:
        if (!in.alerts.contains(r.ref))
          if (auto a = store_.alert(r.ref)) in.alerts.emplace(r.ref, std::move(*a));
        break;
    }
  }
  for (const auto& [id, sc] : in.scans)
    if (!in.samples.contains(sc.plan.sample_id))
      if (auto s = store_.sample(sc.plan.sample_id)) in.samples.emplace(sc.plan.sample_id, std::move(*s));
  p.first_seq = in.rows.front().seq;
  p.last_seq = in.rows.back().seq;
  p.rows = in.rows.size();
  p.statements = build_archive_batch(instrument_, std::string(proto::kVersion), in);
  return p;
}

void ArchiveShipper::drop_ahead() noexcept {
  if (!ahead_.valid()) return;
  try {
    ahead_.get();
  } catch (...) {  // it is read again from the outbox
  }
}

std::size_t ArchiveShipper::ship_once() {
  // The next batch is read and built on another thread while this one is in PostgreSQL's
  // hands: one after the other, the two took about as long. A batch read ahead that came
  // back empty is read again (rows may have come since), and after any failure the outbox
  // is read from its first row.
  const bool was_ahead = ahead_.valid();
  Prepared cur = was_ahead ? ahead_.get() : prepare(0);
  if (cur.rows == 0 && was_ahead) cur = prepare(0);
  if (cur.rows == 0) return 0;
  ahead_ = std::async(std::launch::async, [this, after = cur.last_seq] { return prepare(after); });
  try {
    pg_->exec("BEGIN", {}, "begin");
    for (const auto& st : cur.statements) pg_->exec(st.sql, st.params, "upsert");
    pg_->exec("COMMIT", {}, "commit");
  } catch (...) {
    PQclear(PQexec(pg_->conn, "ROLLBACK"));
    drop_ahead();
    throw;
  }
  // Committed in the archive: now the rows may leave. A crash right here ships the batch
  // again, which the upserts make harmless.
  store_.outbox_remove(cur.first_seq, cur.last_seq);
  std::lock_guard lock(mu_);
  shipped_ += cur.rows;
  ++batches_;
  last_shipped_at_ = utc::now();
  return cur.rows;
}

void ArchiveShipper::refresh_stats() {
  const auto st = store_.outbox_stats();
  std::lock_guard lock(mu_);
  backlog_ = st.rows;
  oldest_at_ = st.oldest_at;
}

void ArchiveShipper::check_backlog_age() {
  std::optional<std::string> oldest;
  bool alerted = false;
  {
    std::lock_guard lock(mu_);
    oldest = oldest_at_;
    alerted = backlog_alerted_;
  }
  bool stale = false;
  std::chrono::seconds age{0};
  if (oldest) {
    try {
      const auto steady_now = std::chrono::steady_clock::now();
      if (aged_row_ != oldest) {
        aged_row_ = oldest;
        aged_base_ = std::max(std::chrono::seconds(0), std::chrono::duration_cast<std::chrono::seconds>(
                                                           utc::Clock::now() - utc::parse(*oldest)));
        aged_since_ = steady_now;
      }
      age = aged_base_ + std::chrono::duration_cast<std::chrono::seconds>(steady_now - aged_since_);
      stale = age > config_.max_backlog_age;
    } catch (const Error&) {
    }
  } else {
    aged_row_.reset();
  }
  if (stale && !alerted && alerts_) {
    std::string why;
    {
      std::lock_guard lock(mu_);
      why = last_error_.empty() ? "" : fmt::format(" (last error: {})", last_error_);
      backlog_alerted_ = true;
    }
    AlertDraft d;
    d.kind = "archive_backlog";
    d.severity = Severity::warning;
    d.dedup_key = "archive:backlog";
    d.message = fmt::format("the central archive is {} s behind: {} outbox rows wait to be shipped{}",
                            age.count(), backlog_, why);
    alerts_->raise(d);
  } else if (!stale && alerted) {
    std::lock_guard lock(mu_);
    backlog_alerted_ = false;  // the next stale backlog raises again
  }
}

void ArchiveShipper::run() {
  auto backoff = std::chrono::milliseconds(200);
  auto next_attempt = std::chrono::steady_clock::now();
  for (;;) {
    {
      std::unique_lock lock(mu_);
      if (stopping_) break;
    }
    bool progressed = false;
    if (std::chrono::steady_clock::now() >= next_attempt) {
      try {
        if (!pg_->conn || PQstatus(pg_->conn) != CONNECTION_OK) {
          connect();
          spdlog::info("archive: connected; shipping the outbox as instrument '{}'", instrument_);
        }
        pending_.store(false, std::memory_order_relaxed);
        progressed = ship_once() > 0;
        backoff = std::chrono::milliseconds(200);
      } catch (const std::exception& e) {
        bool first = false;
        {
          std::lock_guard lock(mu_);
          ++failures_;
          first = last_error_ != e.what();
          last_error_ = e.what();
        }
        if (first) spdlog::warn("{}; retrying (the outbox keeps every row)", e.what());
        disconnect();
        next_attempt = std::chrono::steady_clock::now() + backoff;
        backoff = std::min<std::chrono::milliseconds>(backoff * 2, config_.retry_max);
      }
    }
    refresh_stats();
    check_backlog_age();
    if (progressed) continue;  // drain a backlog without pausing
    std::unique_lock lock(mu_);
    const auto now = std::chrono::steady_clock::now();
    if (now < next_attempt) {
      // Backing off: new rows wait too (the outbox holds them).
      cv_.wait_for(lock, std::min<std::chrono::steady_clock::duration>(next_attempt - now, 1s),
                   [&] { return stopping_; });
    } else {
      cv_.wait_for(lock, 1s, [&] { return stopping_ || pending_.load(); });
    }
  }
  disconnect();
}

json ArchiveShipper::status() const {
  std::lock_guard lock(mu_);
  return json{{"instrument", instrument_},
              {"connected", connected_},
              {"backlog", backlog_},
              {"oldest_at", oldest_at_ ? json(*oldest_at_) : json(nullptr)},
              {"last_shipped_at", last_shipped_at_ ? json(*last_shipped_at_) : json(nullptr)},
              {"shipped", shipped_},
              {"batches", batches_},
              {"failures", failures_},
              {"last_error", last_error_},
              {"schema_version", schema_version_}};
}

}  // namespace gonio::daemon
