// Store — online backup of the store, and its checks and restore (store.hpp).
//
// The copy is made with SQLite's online backup API (https://www.sqlite.org/backup.html) from
// a connection of its own that holds one read transaction from the first step to the last:
// the copy is the store as of that snapshot, and commits made meanwhile by the writer neither
// wait for it (WAL) nor make it start over.
#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <fstream>
#include <thread>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "store/sqlite.hpp"

namespace gonio::daemon {

namespace fs = std::filesystem;

namespace {

// Copies every page of `from` into `to` (both "main"), `pages_per_step` at a time (-1: all at
// once); a busy or locked step is tried again after a moment.
void copy_pages(Store::Connection& from, Store::Connection& to, int pages_per_step,
                const fs::path& dest) {
  sqlite3_backup* b = sqlite3_backup_init(to.db, "main", from.db, "main");
  if (!b)
    throw Error(Errc::io_error, fmt::format("cannot start a backup into {}: {}", dest.string(),
                                            sqlite3_errmsg(to.db)));
  int rc = SQLITE_OK;
  do {
    rc = sqlite3_backup_step(b, pages_per_step);
    if (rc == SQLITE_BUSY || rc == SQLITE_LOCKED) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  } while (rc == SQLITE_OK || rc == SQLITE_BUSY || rc == SQLITE_LOCKED);
  sqlite3_backup_finish(b);
  if (rc != SQLITE_DONE)
    throw Error(Errc::io_error, fmt::format("backup into {} failed: {}", dest.string(), sqlite3_errstr(rc)));
}

int user_version(Store::Connection& c) {
  return db::query_one(c, "PRAGMA user_version", [](const db::Stmt& s) { return static_cast<int>(s.i64(0)); })
      .value_or(0);
}

// The directory entry of a file just renamed into `dir`, made durable.
void sync_dir(const fs::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

Error not_a_store(const fs::path& file, std::string_view why) {
  return Error(Errc::invalid_argument, fmt::format("{} is not a gonio store: {}", file.string(), why), "file");
}

}  // namespace

Store::BackupInfo Store::backup_to(const fs::path& dest, int pages_per_step) const {
  const auto t0 = std::chrono::steady_clock::now();
  std::error_code ec;
  if (fs::exists(dest, ec))
    throw Error(Errc::invalid_state, fmt::format("{} already exists", dest.string()), "file");
  BackupInfo info;
  try {
    Connection src(path_, SQLITE_OPEN_READONLY);
    // The read transaction starts with the first read and lasts until COMMIT: every step
    // copies from this one snapshot.
    src.exec("BEGIN");
    info.schema_version = user_version(src);
    std::tie(info.scans, info.points) =
        db::query_one(src,
                      "SELECT COUNT(*), COALESCE(SUM(points_done) FILTER (WHERE points_pruned_at IS NULL), 0) "
                      "FROM scans",
                      [](const db::Stmt& s) { return std::pair(s.i64(0), s.i64(1)); })
            .value_or(std::pair<std::int64_t, std::int64_t>(0, 0));
    {
      Connection dst(dest, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
      copy_pages(src, dst, pages_per_step, dest);
      // The store is in WAL mode, and so is the copy's header: make the copy one file.
      dst.exec("PRAGMA journal_mode = DELETE");
    }
    src.exec("COMMIT");
  } catch (...) {
    fs::remove(dest, ec);
    throw;
  }
  info.bytes = fs::file_size(dest, ec);
  info.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return info;
}

Store::BackupInfo Store::inspect(const fs::path& file) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec))
    throw Error(Errc::invalid_argument,
                fmt::format("{} {}", file.string(), fs::exists(file, ec) ? "is not a regular file" : "does not exist"),
                "file");
  {
    // The header every SQLite 3 database begins with (https://www.sqlite.org/fileformat.html §1.3.1).
    std::array<char, 16> head{};
    std::ifstream in(file, std::ios::binary);
    if (!in.read(head.data(), head.size()) || std::string_view(head.data(), head.size()) != std::string_view("SQLite format 3\0", 16))
      throw not_a_store(file, "not an SQLite database");
  }
  BackupInfo info;
  try {
    Connection c(file, SQLITE_OPEN_READONLY);
    const auto problems = db::query(c, "PRAGMA integrity_check", [](const db::Stmt& s) { return s.text(0); });
    if (problems.empty() || problems.front() != "ok")
      throw not_a_store(file, fmt::format("SQLite's integrity check fails: {}",
                                          problems.empty() ? std::string("no answer") : problems.front()));
    info.schema_version = user_version(c);
    if (info.schema_version <= 0) throw not_a_store(file, "it has no gonio schema version (user_version 0)");
    if (info.schema_version > kSchemaVersion)
      throw Error(Errc::invalid_argument,
                  fmt::format("{} has schema version {}, newer than this goniod understands ({}); use a newer "
                              "goniod",
                              file.string(), info.schema_version, kSchemaVersion),
                  "file");
    const auto tables =
        db::query_one(c,
                      "SELECT COUNT(*) FROM sqlite_schema WHERE type = 'table' AND "
                      "name IN ('samples', 'scans', 'points', 'alerts', 'audit')",
                      [](const db::Stmt& s) { return s.i64(0); })
            .value_or(0);
    if (tables != 5)
      throw not_a_store(file, fmt::format("schema version {} but not the gonio tables", info.schema_version));
    info.scans = db::query_one(c, "SELECT COUNT(*) FROM scans", [](const db::Stmt& s) { return s.i64(0); }).value_or(0);
    info.points = db::query_one(c, "SELECT COUNT(*) FROM points", [](const db::Stmt& s) { return s.i64(0); }).value_or(0);
  } catch (const Error& e) {
    if (e.field() == "file") throw;
    throw not_a_store(file, e.what());  // SQLite could not read it: "file is not a database", ...
  }
  info.bytes = fs::file_size(file, ec);
  return info;
}

Store::BackupInfo Store::restore(const fs::path& file, const fs::path& state_dir) {
  std::error_code ec;
  const bool existed = fs::exists(state_dir, ec);
  if (existed) {
    if (!fs::is_directory(state_dir, ec))
      throw Error(Errc::invalid_state, fmt::format("{} is not a directory", state_dir.string()), "state_dir");
    const fs::directory_iterator it(state_dir, ec);
    if (ec)
      throw Error(Errc::invalid_state, fmt::format("cannot read {}: {}", state_dir.string(), ec.message()),
                  "state_dir");
    if (it != fs::directory_iterator())
      throw Error(Errc::invalid_state,
                  fmt::format("{} is not empty (it holds {}); restore into an empty or new directory",
                              state_dir.string(), it->path().filename().string()),
                  "state_dir");
  }
  auto info = inspect(file);
  const auto target = state_dir / "goniod.db";
  const auto part = state_dir / "goniod.db.restoring";
  try {
    fs::create_directories(state_dir);
    {
      Connection src(file, SQLITE_OPEN_READONLY);
      Connection dst(part, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
      copy_pages(src, dst, -1, part);
    }
    fs::rename(part, target);
    sync_dir(state_dir);
  } catch (const fs::filesystem_error& e) {
    if (existed) fs::remove(part, ec);
    else fs::remove_all(state_dir, ec);
    throw Error(Errc::io_error, fmt::format("cannot restore into {}: {}", state_dir.string(), e.code().message()),
                "state_dir");
  } catch (...) {
    if (existed) fs::remove(part, ec);
    else fs::remove_all(state_dir, ec);
    throw;
  }
  return info;
}

}  // namespace gonio::daemon
