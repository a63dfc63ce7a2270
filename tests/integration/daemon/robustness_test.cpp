// Hostile and clumsy clients: malformed, oversized and stalled messages, batches and pipelined
// requests over a socket, subscriptions on NDJSON and WebSocket.
#include <gtest/gtest.h>

#include <chrono>
#include <set>
#include <thread>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

std::string small_limits() {
  MockOptions o;
  o.extra = "";
  auto cfg = mock_config(o);
  // 4 KiB messages, 1 s to finish a started one.
  const auto pos = cfg.find("read_timeout_s = 1\n");
  cfg.insert(pos, "max_message_bytes = 4096\n");
  return cfg;
}

TEST(Robustness, MalformedMessagesGetErrorsAndTheConnectionLives) {
  TempDir dir;
  Goniod g(dir.path, small_limits());
  auto c = g.unix_conn();
  c.send_raw("{\"jsonrpc\": \"2.0\", \"id\": 1, \"method\": \n");
  auto r = json::parse(*c.line());
  EXPECT_EQ(r["error"]["code"], -32700);
  EXPECT_TRUE(r["id"].is_null());
  c.send_raw("[1, 2]\n");
  r = json::parse(*c.line());
  ASSERT_TRUE(r.is_array());
  EXPECT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0]["error"]["code"], -32600);
  c.send_raw("\n\n  \n");  // blank lines are ignored
  c.send_raw(R"([{"jsonrpc":"2.0","id":"a","method":"system.info"},{"jsonrpc":"2.0","method":"system.info"},)"
             R"({"jsonrpc":"2.0","id":"b","method":"no.such"}])"
             "\n");
  r = json::parse(*c.line());
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0]["id"], "a");
  EXPECT_TRUE(r[0].contains("result"));
  EXPECT_EQ(r[1]["error"]["code"], -32601);
  EXPECT_TRUE(c.request("system.info").contains("result"));
}

TEST(Robustness, PipelinedRequestsAreAllAnswered) {
  TempDir dir;
  Goniod g(dir.path, mock_config({}));
  const auto check = [](Conn c) {
    // More than a connection keeps in flight, in one write: answers queue up behind each other.
    constexpr int n = 100;
    std::string lines;
    for (int i = 1; i <= n; ++i)
      lines += json{{"jsonrpc", "2.0"}, {"id", i}, {"method", i % 2 ? "system.info" : "auth.whoami"}}.dump() + "\n";
    c.send_raw(lines);
    std::set<int> ids;
    for (int i = 0; i < n; ++i) {
      const auto l = c.line();
      ASSERT_TRUE(l.has_value()) << "answer " << i;
      const auto r = json::parse(*l);
      EXPECT_TRUE(r.contains("result")) << *l;
      ids.insert(r["id"].get<int>());
    }
    EXPECT_EQ(ids.size(), static_cast<std::size_t>(n));
    EXPECT_TRUE(c.request("system.info").contains("result"));
  };
  check(g.unix_conn());
  auto tcp = g.tcp_conn();
  tcp.call("auth.login", {{"token", g.admin_token()}});
  check(std::move(tcp));
}

TEST(Robustness, OversizedMessagesAreRefusedAndTheConnectionClosed) {
  TempDir dir;
  Goniod g(dir.path, small_limits());
  {
    auto c = g.unix_conn();
    c.send_raw(json{{"jsonrpc", "2.0"}, {"id", 1}, {"method", "system.info"}, {"params", {{"pad", std::string(8000, 'x')}}}}.dump() + "\n");
    const auto r = json::parse(*c.line());
    EXPECT_EQ(r["error"]["code"], -32600);
    EXPECT_NE(r["error"]["message"].get<std::string>().find("4096"), std::string::npos);
    EXPECT_TRUE(c.closed_by_peer(5s));
  }
  {
    auto c = g.tcp_conn();  // no newline ever: the buffer limit still holds
    c.send_raw(std::string(10000, '['));
    const auto l = c.line(5s);
    ASSERT_TRUE(l.has_value());
    EXPECT_EQ(json::parse(*l)["error"]["code"], -32600);
    EXPECT_TRUE(c.closed_by_peer(5s));
  }
  const auto r = http(g.http_port(), "POST", "/rpc", std::string(10000, ' '), g.admin_token());
  EXPECT_EQ(r.status, 413);
  // The server is fine.
  EXPECT_TRUE(g.unix_conn().request("system.info").contains("result"));
}

TEST(Robustness, StalledClientsAreDroppedWithoutHoldingOthers) {
  TempDir dir;
  Goniod g(dir.path, small_limits());
  auto stalled = g.tcp_conn();
  stalled.send_raw("{\"jsonrpc\":\"2.0\",\"id\":1,");  // and nothing more
  auto other = g.unix_conn();
  EXPECT_TRUE(other.request("system.info").contains("result"));  // served meanwhile
  EXPECT_TRUE(stalled.closed_by_peer(10s));  // the read timeout is 1 s
  // A stalled HTTP request too.
  Conn h(connect_tcp("127.0.0.1", g.http_port()));
  h.send_raw("POST /rpc HTTP/1.1\r\nHost: x\r\nContent-Length: 100\r\n\r\n{");
  EXPECT_TRUE(h.closed_by_peer(10s));
}

// The read deadline is a field that moves with every message, checked by one outstanding
// timer wait (net/ndjson.cpp): a busy connection outlives the idle timeout, and a line
// started on a connection that idled is held to the (earlier) read timeout, not the idle one.
TEST(Robustness, TheReadDeadlineFollowsEachConnection) {
  TempDir dir;
  auto cfg = small_limits();
  cfg.insert(cfg.find("read_timeout_s = 1\n"), "idle_timeout_s = 6\n");
  Goniod g(dir.path, cfg);
  auto busy = g.unix_conn();
  auto idler = g.unix_conn();
  std::this_thread::sleep_for(500ms);
  idler.send_raw("{\"jsonrpc\":\"2.0\",\"id\":1,");  // and nothing more
  // 1 s to finish the line; the idle deadline it replaces was 5.5 s away.
  EXPECT_TRUE(idler.closed_by_peer(4s));
  // The busy one has sent something every 0.5 s for longer than the idle timeout.
  for (int i = 0; i < 16; ++i) {
    ASSERT_TRUE(busy.request("system.info").contains("result")) << "request " << i;
    std::this_thread::sleep_for(500ms);
  }
  EXPECT_TRUE(busy.request("system.info").contains("result"));
}

TEST(Robustness, SubscriptionsOverNdjsonAndWebSocket) {
  TempDir dir;
  Goniod g(dir.path, mock_config({}));
  auto admin = g.unix_conn();
  admin.call("sample.create", json{{"name", "s"}, {"bsdf", kTrueSample}});
  auto sub = g.unix_conn();
  const auto topics = sub.call("subscribe", json{{"topics", {"points", "state"}}});
  EXPECT_EQ(topics["topics"].size(), 2u);
  WebSocket ws(g.http_port(), g.admin_token());
  ASSERT_EQ(ws.status, 101);
  EXPECT_FALSE(ws.call("subscribe", json{{"topics", {"progress"}}}).contains("error"));
  const auto id = admin.call("scan.submit", json{{"sample", "s"}, {"geometries", {"45as15", "45as25", "45as45"}}})["id"];
  std::set<long long> points;
  bool completed_state = false;
  eventually([&] {
    while (auto n = sub.notification(200ms)) {
      if ((*n)["method"] == "scan.point") points.insert((*n)["params"]["index"].get<long long>());
      if ((*n)["method"] == "scan.state" && (*n)["params"]["state"] == "completed") completed_state = true;
    }
    return completed_state;
  });
  EXPECT_TRUE(completed_state);
  EXPECT_EQ(points, (std::set<long long>{0, 1, 2}));
  // The WebSocket saw the progress up to completion.
  bool ws_completed = false;
  for (auto& n : ws.notes)
    if (n["method"] == "scan.progress" && n["params"]["state"] == "completed") ws_completed = true;
  while (!ws_completed) {
    const auto t = ws.read_text(5s);
    if (!t) break;
    const auto n = json::parse(*t);
    if (n["method"] == "scan.progress") {
      EXPECT_EQ(n["params"]["scan"], id);
      if (n["params"]["state"] == "completed") ws_completed = true;
    }
  }
  EXPECT_TRUE(ws_completed);
  // Unsubscribed: the next scan sends nothing here.
  EXPECT_TRUE(sub.call("unsubscribe")["topics"].empty());
  const auto id2 = admin.call("scan.submit", json{{"sample", "s"}, {"geometries", {"45as15"}}})["id"].get<std::int64_t>();
  wait_state(admin, id2, {"completed"});
  EXPECT_FALSE(sub.notification(300ms).has_value());
}

}  // namespace
}  // namespace gonio::test
