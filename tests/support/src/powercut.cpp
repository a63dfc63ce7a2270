// libgonio_powercut — an LD_PRELOAD shim that lets a test cut the power under a process.
//
// A power cut loses what the page cache held but had not been made durable: writes to a
// file since its last fsync/fdatasync are gone — all of them, or, as a disk may have
// written some of them back on its own, an arbitrary prefix of them. The method is that of
// ALICE (Pillai et al., "All File Systems Are Not Created Equal", OSDI 2014) and
// CrashMonkey (Mohan et al., OSDI 2018), recording the file operations and constructing the
// crash states they allow, and of SQLite's own crash tests (test_journal.c / the "crash"
// VFS of its TCL suite), which drop unsynced sectors at a simulated crash.
//
// Here every write, pwrite and ftruncate to a regular file under $POWERCUT_DIR first
// appends an undo record to "<file>.powercut-undo" (the bytes it overwrites and the file's
// size before); fsync and fdatasync of the file empty that log, since what it undid is now
// durable. The process really writes, so it sees its own writes as with a page cache. The
// test kills it (SIGKILL) at a random instant and then, per file, keeps a random prefix of
// the unsynced writes and undoes the rest, newest first (powercut.hpp: apply_power_cut).
// The shared-memory WAL index (-shm), mapped rather than written, is volatile and deleted.
// Metadata (file creation, rename, unlink) is taken as durable; SQLite syncs its directory
// where that matters.
#include <dlfcn.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

#include <cstdarg>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace {

template <typename F>
F next(const char* name) {
  return reinterpret_cast<F>(::dlsym(RTLD_NEXT, name));
}

using open_t = int (*)(const char*, int, ...);
using openat_t = int (*)(int, const char*, int, ...);
using close_t = int (*)(int);
using write_t = ssize_t (*)(int, const void*, size_t);
using pwrite_t = ssize_t (*)(int, const void*, size_t, off_t);
using ftruncate_t = int (*)(int, off_t);
using sync_t = int (*)(int);

struct Real {
  open_t open = next<open_t>("open");
  open_t open64 = next<open_t>("open64");
  openat_t openat = next<openat_t>("openat");
  openat_t openat64 = next<openat_t>("openat64");
  close_t close = next<close_t>("close");
  write_t write = next<write_t>("write");
  pwrite_t pwrite = next<pwrite_t>("pwrite");
  pwrite_t pwrite64 = next<pwrite_t>("pwrite64");
  ftruncate_t ftruncate = next<ftruncate_t>("ftruncate");
  ftruncate_t ftruncate64 = next<ftruncate_t>("ftruncate64");
  sync_t fsync = next<sync_t>("fsync");
  sync_t fdatasync = next<sync_t>("fdatasync");
};

Real& real() {
  static Real r;
  return r;
}

struct State {
  std::mutex mu;
  std::string dir;                   // realpath of $POWERCUT_DIR + "/", empty: off
  std::map<int, std::string> files;  // tracked fd -> file path
  std::map<std::string, int> logs;   // file path -> its undo log's fd
};

State& state() {
  static State* s = [] {
    auto* st = new State;  // never destroyed: used until the process dies
    if (const char* d = std::getenv("POWERCUT_DIR"); d && *d) {
      if (char* rp = ::realpath(d, nullptr)) {
        st->dir = std::string(rp) + "/";
        std::free(rp);
      }
    }
    return st;
  }();
  return *s;
}

bool ends_with(const std::string& s, const char* suffix) {
  const std::size_t n = std::strlen(suffix);
  return s.size() >= n && s.compare(s.size() - n, n, suffix) == 0;
}

// After a successful open: track the fd when it is a regular file under the directory.
void opened(int fd) {
  if (fd < 0) return;
  State& s = state();
  if (s.dir.empty()) return;
  char link[64];
  std::snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
  char path[4096];
  const auto n = ::readlink(link, path, sizeof path - 1);
  if (n <= 0) return;
  path[n] = '\0';
  const std::string p(path);
  struct stat st {};
  if (p.rfind(s.dir, 0) != 0 || ends_with(p, "-shm") || ends_with(p, ".powercut-undo") ||
      ::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode))
    return;
  std::lock_guard lock(s.mu);
  s.files[fd] = p;
  if (!s.logs.contains(p)) {
    const auto log = p + ".powercut-undo";
    s.logs[p] = real().open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0600);
  }
}

void put_all(int fd, const void* data, std::size_t n) {
  const auto* b = static_cast<const char*>(data);
  while (n > 0) {
    const auto w = real().write(fd, b, n);
    if (w <= 0) std::abort();  // a harness that cannot record must not pretend to
    b += w;
    n -= static_cast<std::size_t>(w);
  }
}

// Before a write of `len` bytes at `offset` (or a truncation to `offset`, len = -1): the
// undo record {offset, old size, n, the n old bytes}. Holds the lock across the write, so
// that records and writes stay in one order.
class Record {
 public:
  Record(int fd, std::int64_t offset, std::int64_t len) : lock_(state().mu) {
    auto& s = state();
    const auto it = s.files.find(fd);
    if (it == s.files.end()) return;
    const int log = s.logs[it->second];
    struct stat st {};
    if (::fstat(fd, &st) != 0 || log < 0) return;
    const std::int64_t size = st.st_size;
    const std::int64_t end = len < 0 ? size : std::min(size, offset + len);
    const std::int64_t n = std::max<std::int64_t>(0, end - offset);
    std::vector<char> old(static_cast<std::size_t>(n));
    if (n > 0 && ::pread(fd, old.data(), old.size(), offset) != n) std::abort();
    const std::int64_t head[3] = {offset, size, n};
    put_all(log, head, sizeof head);
    if (!old.empty()) put_all(log, old.data(), old.size());
  }

 private:
  std::lock_guard<std::mutex> lock_;
};

void synced(int fd) {
  auto& s = state();
  std::lock_guard lock(s.mu);
  const auto it = s.files.find(fd);
  if (it == s.files.end()) return;
  if (const int log = s.logs[it->second]; log >= 0) real().ftruncate(log, 0);
}

int mode_of(int flags, va_list ap) { return (flags & (O_CREAT | O_TMPFILE)) ? va_arg(ap, int) : 0; }

}  // namespace

extern "C" {

int open(const char* path, int flags, ...) {
  va_list ap;
  va_start(ap, flags);
  const int mode = mode_of(flags, ap);
  va_end(ap);
  const int fd = real().open(path, flags, mode);
  opened(fd);
  return fd;
}

int open64(const char* path, int flags, ...) {
  va_list ap;
  va_start(ap, flags);
  const int mode = mode_of(flags, ap);
  va_end(ap);
  const int fd = real().open64(path, flags, mode);
  opened(fd);
  return fd;
}

int openat(int dirfd, const char* path, int flags, ...) {
  va_list ap;
  va_start(ap, flags);
  const int mode = mode_of(flags, ap);
  va_end(ap);
  const int fd = real().openat(dirfd, path, flags, mode);
  opened(fd);
  return fd;
}

int openat64(int dirfd, const char* path, int flags, ...) {
  va_list ap;
  va_start(ap, flags);
  const int mode = mode_of(flags, ap);
  va_end(ap);
  const int fd = real().openat64(dirfd, path, flags, mode);
  opened(fd);
  return fd;
}

int close(int fd) {
  {
    auto& s = state();
    std::lock_guard lock(s.mu);
    s.files.erase(fd);
  }
  return real().close(fd);
}

ssize_t write(int fd, const void* buf, size_t n) {
  const off_t at = ::lseek(fd, 0, SEEK_CUR);
  // O_APPEND writes land at the end; what they overwrite is nothing.
  const bool append = (::fcntl(fd, F_GETFL) & O_APPEND) != 0;
  struct stat st {};
  const std::int64_t offset = append && ::fstat(fd, &st) == 0 ? st.st_size : at;
  if (at < 0) return real().write(fd, buf, n);
  Record r(fd, offset, static_cast<std::int64_t>(n));
  return real().write(fd, buf, n);
}

ssize_t pwrite(int fd, const void* buf, size_t n, off_t offset) {
  Record r(fd, offset, static_cast<std::int64_t>(n));
  return real().pwrite(fd, buf, n, offset);
}

ssize_t pwrite64(int fd, const void* buf, size_t n, off_t offset) {
  Record r(fd, offset, static_cast<std::int64_t>(n));
  return real().pwrite64(fd, buf, n, offset);
}

int ftruncate(int fd, off_t length) {
  Record r(fd, length, -1);
  return real().ftruncate(fd, length);
}

int ftruncate64(int fd, off_t length) {
  Record r(fd, length, -1);
  return real().ftruncate64(fd, length);
}

int fsync(int fd) {
  const int rc = real().fsync(fd);
  if (rc == 0) synced(fd);
  return rc;
}

int fdatasync(int fd) {
  const int rc = real().fdatasync(fd);
  if (rc == 0) synced(fd);
  return rc;
}

}  // extern "C"
