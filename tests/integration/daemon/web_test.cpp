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

// A browser told of a restart by a clean close reconnects; one whose connection is reset
// reports an error. On SIGTERM every WebSocket gets a Close frame with 1001 (going away), the
// peer's answer is read, and the TCP connection ends with a FIN, even when the peer sent a
// request just before it saw the Close frame. Two WebSockets opened one after the other sit
// on the two io threads (one each, in turn); the test keeps each of them alone in turn, so
// one run has its only WebSocket off the main io thread, whose listeners close first.
TEST(Web, AStoppingServerClosesItsWebSocketsWithGoingAway) {
  for (int keep = 0; keep < 2; ++keep) {
    TempDir dir;
    // Long enough that no timeout of goniod's ends a closing handshake in its place.
    auto cfg = mock_config({});
    const std::string harness_timeout = "read_timeout_s = 1\n";
    cfg.replace(cfg.find(harness_timeout), harness_timeout.size(), "read_timeout_s = 60\n");
    Goniod g(dir.path, cfg);
    auto a = std::make_unique<WebSocket>(g.http_port(), g.admin_token());
    auto b = std::make_unique<WebSocket>(g.http_port(), g.admin_token());
    ASSERT_EQ(a->status, 101);
    ASSERT_EQ(b->status, 101);
    auto gone = std::move(keep == 0 ? b : a);
    auto ws = std::move(keep == 0 ? a : b);
    gone->send_close(1000);  // a tab closed before the restart
    while (gone->read_text()) {
    }
    EXPECT_EQ(gone->close_code, 1000);
    EXPECT_TRUE(gone->ends_cleanly());
    gone.reset();  // its socket closed: nothing of it is left on its io thread
    ASSERT_TRUE(ws->call("subscribe", {{"topics", {"alerts"}}}).contains("result"));
    ASSERT_EQ(::kill(g.pid(), SIGTERM), 0);
    ws->send_text(R"({"jsonrpc":"2.0","id":99,"method":"system.info"})");
    while (ws->read_text()) {
    }  // an answer that may have come before the Close frame
    EXPECT_EQ(ws->close_code, 1001) << "keep " << keep;
    std::this_thread::sleep_for(300ms);  // a browser answers when its page gets to it
    ws->send_close(1001);
    EXPECT_TRUE(ws->ends_cleanly()) << "keep " << keep;
    ws.reset();  // as a browser does once the server has closed
    EXPECT_EQ(g.stop(0), 0) << g.log_text();  // the first SIGTERM's clean exit
  }
}

}  // namespace
}  // namespace gonio::test
