// The store's SQLite connection and statements (sqlite.hpp).
#include "store/sqlite.hpp"

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio::daemon {

Store::Connection::Connection(const std::filesystem::path& file, int flags) {
  if (sqlite3_open_v2(file.c_str(), &db, flags | SQLITE_OPEN_NOMUTEX, nullptr) != SQLITE_OK) {
    const std::string msg = db ? sqlite3_errmsg(db) : "out of memory";
    sqlite3_close(db);
    throw Error(Errc::io_error, fmt::format("cannot open {}: {}", file.string(), msg));
  }
  sqlite3_busy_timeout(db, 5000);
  sqlite3_extended_result_codes(db, 1);
}

Store::Connection::~Connection() {
  for (auto& [sql, st] : cache) sqlite3_finalize(st);
  sqlite3_close(db);
}

void Store::Connection::fail(std::string_view what) const {
  const int rc = sqlite3_extended_errcode(db);
  if (owner && is_storage_failure(rc)) throw owner->storage_failure(rc, what, sqlite3_errmsg(db));
  throw Error(Errc::io_error, fmt::format("store: {}: {}", what, sqlite3_errmsg(db)));
}

void Store::Connection::exec(const char* sql) {
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

sqlite3_stmt* Store::Connection::prepare(std::string_view sql) {
  if (const auto it = cache.find(sql); it != cache.end()) return it->second;
  sqlite3_stmt* st = nullptr;
  if (sqlite3_prepare_v3(db, sql.data(), static_cast<int>(sql.size()), SQLITE_PREPARE_PERSISTENT,
                         &st, nullptr) != SQLITE_OK)
    fail(fmt::format("prepare '{}'", sql));
  cache.emplace(std::string(sql), st);
  return st;
}

namespace db {

bool Stmt::step() {
  const int rc = sqlite3_step(st_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  if ((rc & 0xff) == SQLITE_CONSTRAINT)
    throw Error(Errc::invalid_state, fmt::format("store: {}", sqlite3_errmsg(c_.db)));
  c_.fail("step");
}

std::string Stmt::text(int col) const {
  const auto* p = sqlite3_column_text(st_, col);
  return p ? std::string(reinterpret_cast<const char*>(p),
                         static_cast<std::size_t>(sqlite3_column_bytes(st_, col)))
           : std::string();
}

}  // namespace db
}  // namespace gonio::daemon
