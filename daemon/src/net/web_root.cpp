#include "gonio/daemon/net/web_root.hpp"

#include <fstream>
#include <sstream>
#include <system_error>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio::daemon {

namespace fs = std::filesystem;

std::string WebRoot::content_type_of(std::string_view name) {
  const auto dot = name.rfind('.');
  const auto ext = dot == std::string_view::npos ? std::string_view{} : name.substr(dot + 1);
  if (ext == "html") return "text/html; charset=utf-8";
  if (ext == "js" || ext == "mjs") return "text/javascript; charset=utf-8";
  if (ext == "css") return "text/css; charset=utf-8";
  if (ext == "json") return "application/json";
  if (ext == "svg") return "image/svg+xml";
  if (ext == "png") return "image/png";
  if (ext == "ico") return "image/x-icon";
  if (ext == "woff2") return "font/woff2";
  if (ext == "txt") return "text/plain; charset=utf-8";
  return "application/octet-stream";
}

WebRoot WebRoot::load(const fs::path& dir) {
  WebRoot root;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return root;
  std::size_t bytes = 0;
  for (fs::recursive_directory_iterator it(dir, fs::directory_options::none, ec), end; !ec && it != end;
       it.increment(ec)) {
    const auto st = it->symlink_status(ec);
    if (ec || !fs::is_regular_file(st)) continue;  // links and special files are never served
    const auto rel = fs::relative(it->path(), dir, ec);
    if (ec) continue;
    const auto name = "/" + rel.generic_string();
    std::ifstream in(it->path(), std::ios::binary);
    std::ostringstream body;
    body << in.rdbuf();
    if (!in && !in.eof())
      throw Error(Errc::io_error, fmt::format("server.web_root: cannot read {}", it->path().string()));
    WebFile f;
    f.body = std::move(body).str();
    bytes += f.body.size();
    if (root.files_.size() + 1 > kMaxFiles || bytes > kMaxBytes)
      throw Error::invalid("server.web_root",
                           fmt::format("{} holds more than {} files or {} bytes: not a dashboard",
                                       dir.string(), kMaxFiles, kMaxBytes));
    f.content_type = content_type_of(name);
    // Names under /assets/ carry a content hash (web/build.mjs): they never change.
    f.cache_control = name.starts_with("/assets/") ? "public, max-age=31536000, immutable" : "no-cache";
    root.files_.emplace(name, std::move(f));
  }
  if (ec) throw Error(Errc::io_error, fmt::format("server.web_root: {}: {}", dir.string(), ec.message()));
  return root;
}

const WebFile* WebRoot::find(std::string_view target) const {
  auto path = target.substr(0, target.find_first_of("?#"));
  if (path == "/") path = "/index.html";
  const auto it = files_.find(path);
  return it == files_.end() ? nullptr : &it->second;
}

}  // namespace gonio::daemon
