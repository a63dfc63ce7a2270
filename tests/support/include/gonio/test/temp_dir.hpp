// TempDir: a fresh directory under the system temporary directory for one test, removed
// with everything in it when the test ends. The name is made unique by mkdtemp, so tests
// running in parallel (ctest -j, one process per test) never share one.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace gonio::test {

class TempDir {
 public:
  // <temp>/<prefix>-XXXXXX; throws std::runtime_error if it cannot be created.
  explicit TempDir(std::string_view prefix = "gonio-test");
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const noexcept { return path_; }
  // The path of `name` inside the directory, as a string.
  std::string file(std::string_view name) const;
  // Writes `text` to `name` (a relative path), creating its parent directories.
  void write(std::string_view name, std::string_view text) const;

 private:
  std::filesystem::path path_;
};

}  // namespace gonio::test
