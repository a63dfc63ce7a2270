// Store — what a storage failure does (store.hpp, storage.hpp): read-only until the space is
// back, the reserve file, and the writes allowed to use it.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/proto/error.hpp"
#include "store/sqlite.hpp"

namespace gonio::daemon {

using nlohmann::json;

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
      configure_writer(*w);
      writer_ = std::move(w);
      immutable_reads_ = false;
      std::lock_guard pool(pool_mu_);
      readers_.clear();
    }
    db::Transaction t(*writer_);
    db::audit_in(*writer_, "goniod", "store.writable", "", json::object());
    t.commit();
  } catch (const Error& e) {
    if (e.code() != Errc::storage_unavailable) throw;
  }
  return writable();
}

}  // namespace gonio::daemon
