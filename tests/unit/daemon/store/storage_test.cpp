// The storage helpers of a store that must not crash on a full disk: which SQLite results
// are the storage's fault, how free space is described, the reserve file.
#include <sqlite3.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "gonio/daemon/store/storage.hpp"
#include "gonio/daemon/store/store.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {
namespace {

TEST(StorageSpace, TheStoragesFailuresAreToldApartFromTheQuerys) {
  for (int c : {SQLITE_FULL, SQLITE_IOERR, SQLITE_IOERR_WRITE, SQLITE_IOERR_FSYNC, SQLITE_READONLY,
                SQLITE_CANTOPEN})
    EXPECT_TRUE(is_storage_failure(c)) << c;
  for (int c : {SQLITE_CONSTRAINT, SQLITE_ERROR, SQLITE_BUSY, SQLITE_CORRUPT, SQLITE_MISMATCH})
    EXPECT_FALSE(is_storage_failure(c)) << c;
}

TEST(StorageSpace, DescribesTheDirectoryAndItsFreeSpace) {
  SpaceInfo s{3 << 20, false, true};
  EXPECT_EQ(describe_space("/var/lib/gonio", s), "/var/lib/gonio has 3.0 MiB free");
  s.read_only = true;
  EXPECT_EQ(describe_space("/var/lib/gonio", s), "/var/lib/gonio is on a read-only file system");
  EXPECT_TRUE(space_of(std::filesystem::temp_directory_path()).known);
}

TEST(StorageSpace, AStoreKeepsAReserveAndStartsWritable) {
  namespace fs = std::filesystem;
  std::string tmpl = (fs::temp_directory_path() / "gonio-storage-XXXXXX").string();
  ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
  struct Dir {
    fs::path p;
    ~Dir() {
      std::error_code ec;
      fs::remove_all(p, ec);
    }
    const fs::path& path() const { return p; }
  } dir{tmpl};
  Store store(dir.path() / "goniod.db");
  EXPECT_TRUE(store.writable());
  const auto st = store.storage();
  EXPECT_TRUE(st.reserve);
  EXPECT_EQ(std::filesystem::file_size(dir.path() / "goniod.db-reserve"), Store::kReserveBytes);
  EXPECT_EQ(st.dir, std::filesystem::absolute(dir.path()));
  EXPECT_TRUE(store.probe());
}

}  // namespace
}  // namespace gonio::daemon
