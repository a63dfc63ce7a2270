// The central archive (docs/architecture.md §11): the PostgreSQL schema goniod creates and
// migrates, the batch of upserts made from outbox rows, and the shipper thread that sends
// them.
//
// Delivery is at least once (an outbox row leaves the local store only after the archive
// committed its batch) and never twice (every archive table has a key the rows are upserted
// on: points by (instrument, scan_id, idx), so a batch sent again after a crash changes
// nothing). Batches go in outbox order, one PostgreSQL transaction each, so the points of a
// scan arrive in the order they were measured.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <future>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "gonio/daemon/config/config.hpp"
#include "gonio/daemon/store/store.hpp"

namespace gonio::daemon {

class AlertService;

// ---- schema (archive_schema.cpp)

inline constexpr int kArchiveSchemaVersion = 3;
// Migration k brings the archive from version k to k + 1 (one SQL text each).
const std::vector<std::string>& archive_migrations();

// ---- batches (archive_batch.cpp): pure, no connection

// One parameterised statement; params in PostgreSQL's text format, nullopt for NULL.
struct SqlStatement {
  std::string sql;
  std::vector<std::optional<std::string>> params;
};

// What a batch is made from: outbox rows with the current local records they name.
struct ArchiveInput {
  std::vector<OutboxRow> rows;
  std::map<std::int64_t, Sample> samples;
  std::map<std::int64_t, Scan> scans;
  std::map<std::int64_t, Alert> alerts;
};

// The statements that make the archive hold `in`, in the order to run them in one
// transaction: the instrument, samples, scans (each once, its latest local state), scan
// state history, points (in outbox order, chunked under PostgreSQL's parameter limit) and
// alerts. Every statement is an idempotent upsert.
std::vector<SqlStatement> build_archive_batch(const std::string& instrument,
                                              const std::string& goniod_version,
                                              const ArchiveInput& in);
// PostgreSQL array literals: {1.5,2,0.25} and {"a","b \"c\""}.
std::string pg_float_array(const std::vector<double>& v);
std::string pg_text_array(const std::vector<std::string>& v);

// ---- the shipper (archive_shipper.cpp)

class ArchiveShipper {
 public:
  // Turns the store's outbox on. `alerts` (may be null) gets the backlog warning.
  ArchiveShipper(const Config::Archive& config, std::string instrument, Store& store,
                 AlertService* alerts);
  ~ArchiveShipper();
  ArchiveShipper(const ArchiveShipper&) = delete;
  ArchiveShipper& operator=(const ArchiveShipper&) = delete;

  void start();
  // Finishes the batch in flight and stops; what is left stays in the outbox.
  void stop();
  // Wakes the thread (an outbox row was written).
  void wake() noexcept;

  // {instrument, connected, backlog, oldest_at, last_shipped_at, shipped, batches,
  //  failures, last_error, schema_version}
  nlohmann::json status() const;
  const std::string& instrument() const noexcept { return instrument_; }

 private:
  void run();
  bool connect();
  int migrate();  // creates or migrates the archive schema; returns its version
  void disconnect();
  // One batch made ready to send: the outbox rows it covers and its statements.
  struct Prepared {
    std::int64_t first_seq = 0, last_seq = 0;
    std::size_t rows = 0;
    std::vector<SqlStatement> statements;
  };
  // Reads the batch after outbox seq `after` and builds its statements (no connection).
  Prepared prepare(std::int64_t after) const;
  // Waits for the batch being read ahead and forgets it.
  void drop_ahead() noexcept;
  // Ships one batch; returns the rows shipped (0: outbox empty). Throws on failure.
  std::size_t ship_once();
  void refresh_stats();
  void check_backlog_age();

  Config::Archive config_;
  std::string instrument_;
  Store& store_;
  AlertService* alerts_;

  struct Pg;
  std::unique_ptr<Pg> pg_;

  mutable std::mutex mu_;
  std::condition_variable cv_;
  bool stopping_ = false;
  std::atomic<bool> pending_{false};
  std::thread thread_;
  std::future<Prepared> ahead_;  // the next batch, read while one is in flight (shipper thread)

  // status (under mu_)
  bool connected_ = false;
  std::int64_t backlog_ = 0;
  std::optional<std::string> oldest_at_, last_shipped_at_;
  std::uint64_t shipped_ = 0, batches_ = 0, failures_ = 0;
  std::string last_error_;
  int schema_version_ = 0;
  bool backlog_alerted_ = false;
  // The backlog's age counts on the steady clock from when its oldest row was first seen
  // (plus its wall-clock age then, never negative), so that a wall-clock step cannot raise
  // or hold back the backlog warning.
  std::optional<std::string> aged_row_;
  std::chrono::seconds aged_base_{0};
  std::chrono::steady_clock::time_point aged_since_{};
};

}  // namespace gonio::daemon
