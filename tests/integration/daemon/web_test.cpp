// The dashboard's files on the HTTP listener (server.web_root): content types, caching, the
// Content-Security-Policy, and nothing outside the root, whatever the request names.
#include <strings.h>

#include <gtest/gtest.h>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

std::string header(const HttpResponse& r, const std::string& name) {
  std::istringstream in(r.headers);
  std::string line;
  const auto want = name + ":";
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.size() > want.size() && strncasecmp(line.c_str(), want.c_str(), want.size()) == 0) {
      auto v = line.substr(want.size());
      while (!v.empty() && v.front() == ' ') v.erase(0, 1);
      return v;
    }
  }
  return {};
}

struct WebRootFixture {
  TempDir dir;
  fs::path root = dir.path / "web";
  WebRootFixture() {
    fs::create_directories(root / "assets");
    std::ofstream(root / "index.html") << "<!doctype html><title>gonio</title>";
    std::ofstream(root / "assets" / "app-ABC123.js") << "console.log(1)";
    std::ofstream(root / "assets" / "app-ABC123.css") << "body{}";
    std::ofstream(dir.path / "secret.txt") << "not for the web";
    fs::create_symlink(dir.path / "secret.txt", root / "link.txt");
  }
  std::string config() const {
    auto cfg = mock_config({});
    cfg.insert(cfg.find("read_timeout_s = 1\n"), "web_root = \"" + root.string() + "\"\n");
    return cfg;
  }
};

TEST(Web, ServesTheDashboardWithTypesCachingAndAStrictPolicy) {
  WebRootFixture w;
  Goniod g(w.dir.path / "state", w.config());
  const auto index = http(g.http_port(), "GET", "/", "");
  ASSERT_EQ(index.status, 200) << index.headers;
  EXPECT_EQ(index.body, "<!doctype html><title>gonio</title>");
  EXPECT_EQ(header(index, "Content-Type"), "text/html; charset=utf-8");
  EXPECT_EQ(header(index, "Cache-Control"), "no-cache");
  const auto csp = header(index, "Content-Security-Policy");
  EXPECT_NE(csp.find("default-src 'self'"), std::string::npos) << csp;
  EXPECT_NE(csp.find("script-src 'self'"), std::string::npos) << csp;
  EXPECT_NE(csp.find("connect-src 'self' ws://127.0.0.1 wss://127.0.0.1"), std::string::npos) << csp;
  EXPECT_EQ(csp.find("unsafe"), std::string::npos) << csp;
  EXPECT_EQ(header(index, "X-Content-Type-Options"), "nosniff");

  EXPECT_EQ(http(g.http_port(), "GET", "/index.html?v=2", "").status, 200);
  const auto js = http(g.http_port(), "GET", "/assets/app-ABC123.js", "");
  ASSERT_EQ(js.status, 200);
  EXPECT_EQ(header(js, "Content-Type"), "text/javascript; charset=utf-8");
  EXPECT_EQ(header(js, "Cache-Control"), "public, max-age=31536000, immutable");
  EXPECT_EQ(header(http(g.http_port(), "GET", "/assets/app-ABC123.css", ""), "Content-Type"),
            "text/css; charset=utf-8");

  EXPECT_EQ(http(g.http_port(), "GET", "/nothing.js", "").status, 404);
  EXPECT_EQ(http(g.http_port(), "POST", "/", "{}").status, 404);  // only GET serves files
  // The API is where it was.
  EXPECT_EQ(http(g.http_port(), "POST", "/rpc", R"({"jsonrpc":"2.0","id":1,"method":"rpc.discover"})").status, 200);
}

TEST(Web, NoRequestReachesAFileOutsideTheRoot) {
  WebRootFixture w;
  Goniod g(w.dir.path / "state", w.config());
  for (const std::string& target : std::vector<std::string>{
           "/../secret.txt", "/assets/../../secret.txt", "/%2e%2e/secret.txt", "/..%2fsecret.txt",
        "/assets/..%2f..%2fsecret.txt", "/./index.html", "//index.html", "/assets/../index.html",
        "/link.txt", "/assets", "/assets/", "/" + w.dir.path.string() + "/secret.txt",
        "/index.html%00.js", "\\..\\secret.txt"}) {
    const auto r = http(g.http_port(), "GET", target, "");
    EXPECT_NE(r.status, 200) << target;
    EXPECT_EQ(r.body.find("not for the web"), std::string::npos) << target;
  }
}

TEST(Web, WithoutADashboardTheListenerServesOnlyTheApi) {
  TempDir dir;
  auto cfg = mock_config({});
  cfg.insert(cfg.find("read_timeout_s = 1\n"), "web_root = \"" + (dir.path / "none").string() + "\"\n");
  Goniod g(dir.path / "state", cfg);
  EXPECT_EQ(http(g.http_port(), "GET", "/", "").status, 404);
  EXPECT_EQ(http(g.http_port(), "POST", "/rpc", R"({"jsonrpc":"2.0","id":1,"method":"rpc.discover"})").status, 200);
}

}  // namespace
}  // namespace gonio::test
