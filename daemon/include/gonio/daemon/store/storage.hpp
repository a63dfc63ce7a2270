// Storage — the free space of the store's file system and the store's reserve file
// (docs/architecture.md §5, "disk full is a pause").
//
// A full disk, a file system remounted read-only or a failing disk makes every store write
// fail. goniod does not exit over it: the Store turns read-only (reads go on, writes are
// refused with Error(storage_unavailable) naming the directory and its free space), the
// running scan pauses with a `storage` alert, and the store takes writes again once the
// space is back. The pause and its alert must not need the space that is missing, so the
// store keeps a reserve file beside the database, released when the disk fills (the
// "ballast file" of many databases and log servers), and the alert is published and kept in
// memory when even that cannot be written (a read-only file system).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

namespace gonio::daemon {

struct SpaceInfo {
  std::uint64_t free_bytes = 0;  // available to an unprivileged writer (statvfs f_bavail)
  bool read_only = false;        // the file system is mounted read-only
  bool known = false;            // statvfs answered
};

SpaceInfo space_of(const std::filesystem::path& dir) noexcept;

// "/var/lib/gonio has 0.3 MiB free" / "/var/lib/gonio is on a read-only file system"
std::string describe_space(const std::filesystem::path& dir, const SpaceInfo& s);

// SQLite result codes that are the storage's fault, not the query's: SQLITE_FULL, any
// SQLITE_IOERR_*, SQLITE_READONLY (a read-only file system) and SQLITE_CANTOPEN (a journal
// that cannot be created).
bool is_storage_failure(int sqlite_code) noexcept;

// The reserve file: `bytes` written and fsynced (so that the blocks are really allocated;
// a sparse file would free nothing). Returns false when it could not be made in full (no
// partial file is left).
bool make_reserve(const std::filesystem::path& file, std::uint64_t bytes) noexcept;

}  // namespace gonio::daemon
