// The store's SQLite layer: a connection with its cached statements, a reader borrowed from
// the pool, a statement in use, a write transaction, and query() / query_one() for the
// select-bind-step-read shape every table's readers share. Private to the store: its files
// include it, nothing else does.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "gonio/daemon/store/store.hpp"

namespace gonio::daemon {

struct Store::Connection {
  sqlite3* db = nullptr;
  std::map<std::string, sqlite3_stmt*, std::less<>> cache;
  Store* owner = nullptr;  // the writer's store: its storage failures make the store read-only

  Connection(const std::filesystem::path& file, int flags);
  ~Connection();
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  [[noreturn]] void fail(std::string_view what) const;
  void exec(const char* sql);
  // Around every write of the writer connection (storage.hpp).
  void begin_write() {
    if (owner) owner->before_write();
  }
  void committed() {
    if (owner) owner->after_commit();
  }
  sqlite3_stmt* prepare(std::string_view sql);
  std::int64_t last_insert_id() const { return sqlite3_last_insert_rowid(db); }
  std::int64_t changes() const { return sqlite3_changes(db); }
};

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

namespace db {

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
  // Binds the arguments to ?1, ?2, ... in order.
  template <typename... Args>
  Stmt& bind_all(const Args&... args) {
    int i = 0;
    (bind(++i, args), ...);
    return *this;
  }
  // true while rows come
  bool step();
  void run() {
    while (step()) {
    }
  }
  std::int64_t i64(int col) const { return sqlite3_column_int64(st_, col); }
  double f64(int col) const { return sqlite3_column_double(st_, col); }
  bool null(int col) const { return sqlite3_column_type(st_, col) == SQLITE_NULL; }
  std::string text(int col) const;
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

// Every row of `sql` with `args` bound, each made by `read`.
template <typename Read, typename... Args>
auto query(Connection& c, std::string_view sql, Read read, const Args&... args) {
  Stmt s(c, sql);
  s.bind_all(args...);
  std::vector<decltype(read(s))> out;
  while (s.step()) out.push_back(read(s));
  return out;
}

// The first row of `sql` with `args` bound, if there is one.
template <typename Read, typename... Args>
auto query_one(Connection& c, std::string_view sql, Read read, const Args&... args)
    -> std::optional<decltype(read(std::declval<const Stmt&>()))> {
  Stmt s(c, sql);
  s.bind_all(args...);
  if (!s.step()) return std::nullopt;
  return read(s);
}

// Runs a statement that returns no rows.
template <typename... Args>
void execute(Connection& c, std::string_view sql, const Args&... args) {
  Stmt(c, sql).bind_all(args...).run();
}

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

// An audit row, inside the caller's write (audit.cpp).
void audit_in(Connection& c, const std::string& actor, const std::string& action,
              const std::string& target, const nlohmann::json& detail);

}  // namespace db
}  // namespace gonio::daemon
