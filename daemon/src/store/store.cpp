// Store — opening the file and the pool of reader connections (store.hpp). The tables are
// one file each beside this one; the schema and its migrations are in schema.cpp.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/proto/error.hpp"
#include "store/sqlite.hpp"

namespace gonio::daemon {

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
    configure_writer(*writer_);
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

Store::~Store() = default;

void Store::configure_writer(Connection& c) const {
  // A file with nothing written yet takes this at once (schema.cpp, migration 7): WAL mode
  // writes the header, after which only a VACUUM changes it. Asked of an existing file it
  // would be a write, which a full disk refuses.
  std::error_code ec;
  if (std::filesystem::file_size(path_, ec) == 0 || ec) c.exec("PRAGMA auto_vacuum = INCREMENTAL");
  c.exec("PRAGMA journal_mode = WAL");
  c.exec(synchronous_full_ ? "PRAGMA synchronous = FULL" : "PRAGMA synchronous = NORMAL");
  c.exec("PRAGMA foreign_keys = ON");
}

}  // namespace gonio::daemon
