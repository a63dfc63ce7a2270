// The dashboard's file store: what it reads, what it serves, and what it refuses.
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "gonio/daemon/net/web_root.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {
namespace {

namespace fs = std::filesystem;

struct Dir {
  fs::path path;
  Dir() {
    std::string tmpl = (fs::temp_directory_path() / "gonio-webroot-XXXXXX").string();
    if (!::mkdtemp(tmpl.data())) throw std::runtime_error("mkdtemp");
    path = tmpl;
  }
  ~Dir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

TEST(WebRoot, ServesExactlyTheFilesThatWereThere) {
  Dir d;
  fs::create_directories(d.path / "web" / "assets");
  std::ofstream(d.path / "web" / "index.html") << "<html>";
  std::ofstream(d.path / "web" / "assets" / "app-1.js") << "js";
  std::ofstream(d.path / "outside.txt") << "secret";
  fs::create_symlink(d.path / "outside.txt", d.path / "web" / "link.txt");
  const auto root = WebRoot::load(d.path / "web");
  EXPECT_EQ(root.size(), 2u);  // the link is not served
  ASSERT_NE(root.find("/"), nullptr);
  EXPECT_EQ(root.find("/")->body, "<html>");
  EXPECT_EQ(root.find("/?a=b")->cache_control, "no-cache");
  ASSERT_NE(root.find("/assets/app-1.js#x"), nullptr);
  EXPECT_EQ(root.find("/assets/app-1.js")->cache_control, "public, max-age=31536000, immutable");
  EXPECT_EQ(root.find("/assets/app-1.js")->content_type, "text/javascript; charset=utf-8");
  for (const char* t : {"/link.txt", "/../outside.txt", "/assets/../index.html", "/assets", "",
                        "index.html", "/INDEX.HTML"})
    EXPECT_EQ(root.find(t), nullptr) << t;
}

TEST(WebRoot, AMissingDirectoryServesNothing) {
  Dir d;
  const auto root = WebRoot::load(d.path / "none");
  EXPECT_TRUE(root.empty());
  EXPECT_EQ(root.find("/"), nullptr);
}

TEST(WebRoot, RefusesATreeTooBigToBeADashboard) {
  Dir d;
  for (std::size_t i = 0; i <= WebRoot::kMaxFiles; ++i) std::ofstream(d.path / std::to_string(i)) << "x";
  try {
    (void)WebRoot::load(d.path);
    FAIL() << "loaded";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "server.web_root");
  }
}

TEST(WebRoot, ContentTypes) {
  EXPECT_EQ(WebRoot::content_type_of("/index.html"), "text/html; charset=utf-8");
  EXPECT_EQ(WebRoot::content_type_of("/a.css"), "text/css; charset=utf-8");
  EXPECT_EQ(WebRoot::content_type_of("/a.svg"), "image/svg+xml");
  EXPECT_EQ(WebRoot::content_type_of("/a"), "application/octet-stream");
  EXPECT_EQ(WebRoot::content_type_of("/a.exe"), "application/octet-stream");
}

}  // namespace
}  // namespace gonio::daemon
