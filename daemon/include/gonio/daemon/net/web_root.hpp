// The dashboard's files (web/, installed to /usr/share/gonio/web), served by the HTTP
// listener (docs/architecture.md §12).
//
// The whole tree is read into memory at start: a request is answered by an exact lookup of
// its path among the files that were there, so no request can name a file outside the root
// (no "..", no links, no encodings to decode), and no io thread waits on the disk. The tree
// is small (the bundle is limited to 200 kB gzipped); a tree over kMaxBytes or kMaxFiles is
// refused rather than served in part.
#pragma once

#include <cstddef>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>

namespace gonio::daemon {

struct WebFile {
  std::string body;
  std::string content_type;
  std::string cache_control;  // hashed assets: immutable; index.html: no-cache
};

class WebRoot {
 public:
  static constexpr std::size_t kMaxFiles = 256;
  static constexpr std::size_t kMaxBytes = 32u << 20;

  WebRoot() = default;  // serves nothing

  // Reads `dir` (regular files only, symbolic links skipped). A missing directory gives an
  // empty root (goniod runs without a dashboard); one over the limits throws Error
  // (invalid_argument, field `server.web_root`).
  static WebRoot load(const std::filesystem::path& dir);

  // The file for a request target ("/", "/assets/app-X.js?v=1"); nullptr for anything else.
  const WebFile* find(std::string_view target) const;

  bool empty() const { return files_.empty(); }
  std::size_t size() const { return files_.size(); }

  // By file name extension; application/octet-stream for the unknown.
  static std::string content_type_of(std::string_view name);

 private:
  std::map<std::string, WebFile, std::less<>> files_;  // "/index.html", "/assets/app-X.js"
};

}  // namespace gonio::daemon
