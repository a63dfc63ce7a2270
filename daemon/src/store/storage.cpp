// Free space and the reserve file (storage.hpp).
#include "gonio/daemon/store/storage.hpp"

#include <fcntl.h>
#include <sqlite3.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <vector>

#include <fmt/format.h>

namespace gonio::daemon {

SpaceInfo space_of(const std::filesystem::path& dir) noexcept {
  SpaceInfo s;
  struct statvfs v {};
  if (::statvfs(dir.c_str(), &v) != 0) return s;
  s.known = true;
  s.free_bytes = static_cast<std::uint64_t>(v.f_bavail) * static_cast<std::uint64_t>(v.f_frsize);
  s.read_only = (v.f_flag & ST_RDONLY) != 0;
  return s;
}

std::string describe_space(const std::filesystem::path& dir, const SpaceInfo& s) {
  if (!s.known) return fmt::format("the free space of {} is unknown", dir.string());
  if (s.read_only) return fmt::format("{} is on a read-only file system", dir.string());
  return fmt::format("{} has {:.1f} MiB free", dir.string(), static_cast<double>(s.free_bytes) / (1 << 20));
}

bool is_storage_failure(int code) noexcept {
  switch (code & 0xff) {
    case SQLITE_FULL:
    case SQLITE_IOERR:
    case SQLITE_READONLY:
    case SQLITE_CANTOPEN: return true;
    default: return false;
  }
}

bool make_reserve(const std::filesystem::path& file, std::uint64_t bytes) noexcept {
  const auto tmp = file.string() + ".new";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) return false;
  // Written, not fallocate()d: tmpfs and some file systems do not support it everywhere,
  // and written blocks are allocated on every one.
  const std::vector<char> block(64 << 10, 0);
  bool ok = true;
  for (std::uint64_t done = 0; ok && done < bytes;) {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(block.size(), bytes - done));
    const auto w = ::write(fd, block.data(), n);
    if (w <= 0) ok = false;
    else done += static_cast<std::uint64_t>(w);
  }
  ok = ok && ::fsync(fd) == 0;
  ok = (::close(fd) == 0) && ok;
  ok = ok && ::rename(tmp.c_str(), file.c_str()) == 0;
  if (!ok) ::unlink(tmp.c_str());
  return ok;
}

}  // namespace gonio::daemon
