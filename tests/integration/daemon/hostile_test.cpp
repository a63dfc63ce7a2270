// Hostile clients against a real goniod: amplifying batches, peers that do not read or do
// not log in, browsers on foreign pages, revoked tokens on live connections; and the fault
// latch across a crash; a listener out of file descriptors.
#include <grp.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

// Peak resident memory of a process (VmHWM), in bytes.
std::size_t peak_rss(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line))
    if (line.starts_with("VmHWM:")) return std::stoull(line.substr(6)) * 1024;
  return 0;
}

std::string with_server(const std::string& keys, MockOptions o = {}) {
  auto cfg = mock_config(o);
  cfg.insert(cfg.find("read_timeout_s = 1\n"), keys);
  return cfg;
}

json net_stats(const Goniod& g) { return g.unix_conn().call("system.info")["net"]; }

TEST(Hostile, AmplifyingBatchesAreRefusedBeforeTheyCostMemory) {
  TempDir dir;
  // Room for 128 copies of the OpenRPC document in one answer (~8.4 MB, over the default
  // 8 MiB; the batch assembly budget, 12 MiB, stays at its default).
  Goniod g(dir.path, with_server("max_response_bytes = 16777216\n"));
  auto c = g.tcp_conn();  // no login: what anyone on the machine can send
  const std::string discover = R"({"jsonrpc":"2.0","id":1,"method":"rpc.discover"})";
  std::string batch = "[";
  while (batch.size() + discover.size() + 2 < 1000000) batch += (batch.size() > 1 ? "," : "") + discover;
  c.send_raw(batch + "]\n");
  auto r = json::parse(*c.line());
  ASSERT_TRUE(r.is_object()) << r.dump().substr(0, 200);
  EXPECT_EQ(r["error"]["code"], -32600);
  EXPECT_NE(r["error"]["message"].get<std::string>().find("server.max_batch = 128"), std::string::npos) << r.dump();
  std::string empties = "[";
  while (empties.size() < 1000000) empties += "{},";
  empties.back() = ']';
  c.send_raw(empties + "\n");
  r = json::parse(*c.line());
  EXPECT_EQ(r["error"]["code"], -32600);
  // One request whose params are a million tiny values: refused on the count.
  std::string zeros(900000, '0');
  for (std::size_t i = 1; i < zeros.size(); i += 2) zeros[i] = ',';
  c.send_raw(R"({"jsonrpc":"2.0","id":2,"method":"rpc.discover","params":{"x":[)" + zeros + "0]}}\n");
  r = json::parse(*c.line());
  EXPECT_EQ(r["error"]["code"], -32600);
  EXPECT_NE(r["error"]["message"].get<std::string>().find("JSON values"), std::string::npos) << r.dump();
  // The largest batch allowed is answered in full, and the connection lives on.
  std::string ok = "[";
  for (int i = 0; i < 128; ++i) ok += (i ? "," : "") + json{{"jsonrpc", "2.0"}, {"id", i}, {"method", "rpc.discover"}}.dump();
  c.send_raw(ok + "]\n");
  r = json::parse(*c.line());
  ASSERT_TRUE(r.is_array());
  EXPECT_EQ(r.size(), 128u);
  EXPECT_TRUE(r[127].contains("result")) << r[127].dump().substr(0, 400);
  EXPECT_LT(peak_rss(g.pid()), std::size_t{128} << 20) << "goniod's peak RSS";
}

// A peer that asks for a batch of reads and hangs up before they start: they are skipped
// (the worker is busy with another client's prediction meanwhile), that client is answered,
// and the batch's room in the assembly budget is given back.
TEST(Hostile, ReadsOfAPeerThatHungUpAreSkipped) {
  TempDir dir;
  Goniod g(dir.path, with_server("rpc_threads = 1\n"));
  auto tech = g.unix_conn();
  auto quitter = g.unix_conn();
  tech.send_raw(json{{"jsonrpc", "2.0"}, {"id", 1}, {"method", "twin.predict"},
                     {"params", {{"bsdf", "conductor:alpha=0.05,eta=0.2,k=3.9"}, {"grids", {"in=45;out=-30:80:1"}},
                                 {"rel_se", 0.002}}}}.dump() + "\n");
  std::string batch = "[";
  for (int i = 0; i < 128; ++i)
    batch += (i ? "," : "") + json{{"jsonrpc", "2.0"}, {"id", i}, {"method", "scan.points"}, {"params", {{"scan", 1}}}}.dump();
  quitter.send_raw(batch + "]\n");
  { Conn gone = std::move(quitter); }  // hangs up without reading
  const auto answer = tech.line(120s);
  ASSERT_TRUE(answer);
  EXPECT_TRUE(json::parse(*answer).contains("result")) << answer->substr(0, 300);
  json rpc;
  EXPECT_TRUE(eventually([&] {
    rpc = g.unix_conn().call("system.info")["rpc"];
    return rpc["building_bytes"].get<std::size_t>() == 0 && rpc["abandoned"].get<std::size_t>() > 0;
  }, 20s)) << rpc.dump();
  // Most of the batch was still waiting for the worker when the peer left.
  EXPECT_GE(rpc["abandoned"].get<std::size_t>(), 100u) << rpc.dump();
}

TEST(Hostile, ResponsesOverTheLimitBecomeErrorsNotPartialReplies) {
  // Two rpc.discover answers fit, the third does not: the limit is 2.5 answers, measured on
  // a first goniod (the document grows with the API).
  std::size_t answer = 0;
  {
    TempDir first;
    Goniod g(first.path, with_server(""));
    auto c = g.unix_conn();
    answer = json{{"jsonrpc", "2.0"}, {"id", 0}, {"result", c.call("rpc.discover")}}.dump().size();
  }
  TempDir dir;
  Goniod g(dir.path, with_server(fmt::format("max_response_bytes = {}\n", answer * 5 / 2)));
  auto c = g.unix_conn();
  std::string batch = "[";
  for (int i = 0; i < 5; ++i) batch += (i ? "," : "") + json{{"jsonrpc", "2.0"}, {"id", i}, {"method", "rpc.discover"}}.dump();
  c.send_raw(batch + "]\n");
  const auto r = json::parse(*c.line());
  ASSERT_TRUE(r.is_array());
  ASSERT_EQ(r.size(), 5u);  // every call answered
  EXPECT_TRUE(r[0].contains("result"));
  EXPECT_TRUE(r[1].contains("result"));
  for (int i = 2; i < 5; ++i) {
    EXPECT_EQ(r[i]["id"], i);
    EXPECT_EQ(r[i]["error"]["code"], -32008) << r[i].dump();
    EXPECT_NE(r[i]["error"]["message"].get<std::string>().find("max_response_bytes"), std::string::npos);
  }
}

TEST(Hostile, ASingleAnswerOverTheLimitBecomesAnErrorWithItsId) {
  TempDir dir;
  Goniod g(dir.path, with_server("max_response_bytes = 65536\n"));
  auto c = g.unix_conn();
  const std::string long_name(40000, 'x');
  // Refusals quote what they refuse: a 40 kB unknown member (named twice, in the message and
  // in data.field) or method name makes an answer over the limit, refused before or after
  // dispatch.
  c.send_raw(json{{"jsonrpc", "2.0"}, {"id", 7}, {"method", "system.info"}, {long_name, 1}}.dump() + "\n");
  c.send_raw(json{{"jsonrpc", "2.0"}, {"id", "m"}, {"method", long_name + long_name}}.dump() + "\n");
  for (const json& id : {json(7), json("m")}) {
    const auto line = c.line();
    ASSERT_TRUE(line);
    const auto r = json::parse(*line);
    EXPECT_EQ(r["id"], id) << r.dump().substr(0, 200);
    EXPECT_EQ(r["error"]["code"], -32008) << r.dump().substr(0, 200);
    EXPECT_NE(r["error"]["message"].get<std::string>().find("max_response_bytes"), std::string::npos);
  }
  // The connection still answers within the limit.
  c.send_raw(json{{"jsonrpc", "2.0"}, {"id", 8}, {"method", "system.info"}}.dump() + "\n");
  const auto ok = json::parse(*c.line());
  EXPECT_TRUE(ok.contains("result"));
}

TEST(Hostile, APeerThatDoesNotReadIsDroppedAndCounted) {
  TempDir dir;
  Goniod g(dir.path, with_server("max_queue_bytes = 65536\nwrite_timeout_s = 1\n"));
  auto c = g.unix_conn();
  // Small receive buffer: the kernel takes little of what goniod writes.
  int small = 4096;
  ::setsockopt(c.fd(), SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
  std::string lines;
  for (int i = 0; i < 400; ++i) lines += json{{"jsonrpc", "2.0"}, {"id", i}, {"method", "rpc.discover"}}.dump() + "\n";
  std::thread writer([&] {
    try {
      c.send_raw(lines);
    } catch (const std::exception&) {  // goniod may close before all is sent
    }
  });
  const bool dropped = eventually([&] { return net_stats(g)["slow_readers_dropped"].get<int>() >= 1; }, 20s);
  writer.join();
  EXPECT_TRUE(dropped) << net_stats(g).dump();
  EXPECT_TRUE(c.closed_by_peer(10s));
  EXPECT_LT(net_stats(g)["buffered_bytes"].get<std::size_t>(), std::size_t{65536});
  EXPECT_TRUE(g.unix_conn().request("system.info").contains("result"));  // the server carries on
}

// A listener out of file descriptors backs off (counted, logged) rather than spinning on the
// connection it cannot take, and serves again once descriptors are free.
TEST(Hostile, AListenerOutOfDescriptorsBacksOffAndRecovers) {
  TempDir dir;
  Goniod g(dir.path, mock_config({}));
  rlimit was{};
  ASSERT_EQ(::prlimit(g.pid(), RLIMIT_NOFILE, nullptr, &was), 0);
  const auto open_now = static_cast<rlim_t>(std::distance(
      fs::directory_iterator("/proc/" + std::to_string(g.pid()) + "/fd"), fs::directory_iterator{}));
  rlimit tight{open_now + 3, was.rlim_max};  // room for three more connections
  ASSERT_EQ(::prlimit(g.pid(), RLIMIT_NOFILE, &tight, nullptr), 0);
  std::vector<int> peers;
  for (int i = 0; i < 8; ++i) peers.push_back(connect_tcp("127.0.0.1", g.tcp_port()));
  const bool backed_off = eventually([&] {
    return g.log_text().find("accept: Too many open files; retrying in") != std::string::npos;
  }, 20s);
  for (int fd : peers) ::close(fd);
  ASSERT_EQ(::prlimit(g.pid(), RLIMIT_NOFILE, &was, nullptr), 0);
  EXPECT_TRUE(backed_off) << g.log_text();
  // Serving again: a new TCP peer gets its answer (after at most one 2 s back-off).
  auto c = g.tcp_conn();
  EXPECT_TRUE(c.request("rpc.discover").contains("result"));
  EXPECT_GE(net_stats(g)["accept_backoffs"].get<int>(), 1);
}

TEST(Hostile, PeersThatDoNotLogInAreDropped) {
  TempDir dir;
  Goniod g(dir.path, with_server("login_timeout_s = 1\n"));
  auto idle = g.tcp_conn();
  auto talker = g.tcp_conn();
  EXPECT_TRUE(talker.request("rpc.discover").contains("result"));  // answering is not logging in
  auto good = g.tcp_conn();
  good.call("auth.login", {{"token", g.admin_token()}});
  WebSocket ws(g.http_port());
  ASSERT_EQ(ws.status, 101);
  EXPECT_TRUE(idle.closed_by_peer(10s));
  EXPECT_TRUE(talker.closed_by_peer(10s));
  EXPECT_TRUE(ws.closed_by_peer());
  EXPECT_GE(net_stats(g)["login_timeouts"].get<int>(), 3);
  EXPECT_TRUE(good.request("system.info").contains("result"));
}

TEST(Hostile, AWebSocketMessageMustCompleteWithinTheReadTimeout) {
  TempDir dir;
  Goniod g(dir.path, mock_config({}));
  WebSocket ws(g.http_port(), g.admin_token());
  ASSERT_EQ(ws.status, 101);
  EXPECT_TRUE(ws.call("system.info").contains("result"));
  // A text frame without FIN: the message has started and never ends.
  Conn& raw = ws.conn();
  const std::string part = R"({"jsonrpc":"2.0",)";
  std::string f;
  f += static_cast<char>(0x01);  // text, FIN = 0
  f += static_cast<char>(0x80 | part.size());
  for (int i = 0; i < 4; ++i) f += '\0';  // mask 0
  f += part;
  raw.send_raw(f);
  EXPECT_TRUE(ws.closed_by_peer());
}

// One raw HTTP/1.1 exchange; `headers` end with CRLF each.
HttpResponse raw_http(int port, const std::string& head, const std::string& body = {}) {
  Conn c(connect_tcp("127.0.0.1", port));
  c.send_raw(head + "Content-Length: " + std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n" + body);
  std::string all;
  for (;;) {
    pollfd p{c.fd(), POLLIN, 0};
    if (::poll(&p, 1, 10000) <= 0) break;
    char b[65536];
    const auto n = ::recv(c.fd(), b, sizeof b, 0);
    if (n <= 0) break;
    all.append(b, static_cast<std::size_t>(n));
    // An upgraded connection stays open: its head is all there is.
    if (all.starts_with("HTTP/1.1 101") && all.find("\r\n\r\n") != std::string::npos) break;
  }
  HttpResponse r;
  const auto end = all.find("\r\n\r\n");
  if (end == std::string::npos || all.size() < 12) return r;
  r.status = std::stoi(all.substr(9, 3));
  r.headers = all.substr(0, end);
  r.body = all.substr(end + 4);
  return r;
}

TEST(Hostile, BrowsersOnForeignPagesAreKeptOut) {
  TempDir dir;
  Goniod g(dir.path, with_server("allowed_origins = [\"http://lab-portal.example:8080\"]\n"));
  const int port = g.http_port();
  const auto host = "127.0.0.1:" + std::to_string(port);
  const std::string call = R"({"jsonrpc":"2.0","id":1,"method":"rpc.discover"})";
  // A plain form post (what any page can send across origins) is refused on its type.
  auto r = raw_http(port, "POST /rpc HTTP/1.1\r\nHost: " + host + "\r\nContent-Type: text/plain\r\n", call);
  EXPECT_EQ(r.status, 415);
  EXPECT_EQ(json::parse(r.body)["error"]["data"]["field"], "Content-Type");
  r = raw_http(port, "POST /rpc HTTP/1.1\r\nHost: " + host + "\r\nContent-Type: application/x-www-form-urlencoded\r\n", call);
  EXPECT_EQ(r.status, 415);
  r = raw_http(port, "POST /rpc HTTP/1.1\r\nHost: " + host + "\r\nContent-Type: Application/JSON; charset=utf-8\r\n", call);
  EXPECT_EQ(r.status, 200);
  // A foreign Origin is refused; the listener's own and the configured one are not.
  r = raw_http(port, "POST /rpc HTTP/1.1\r\nHost: " + host + "\r\nOrigin: http://evil.example\r\nContent-Type: application/json\r\n", call);
  EXPECT_EQ(r.status, 403);
  EXPECT_EQ(json::parse(r.body)["error"]["data"]["field"], "Origin");
  r = raw_http(port, "POST /rpc HTTP/1.1\r\nHost: " + host + "\r\nOrigin: http://" + host + "\r\nContent-Type: application/json\r\n", call);
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.headers.find("Access-Control-Allow-Origin"), std::string::npos);  // no CORS by default
  r = raw_http(port, "OPTIONS /rpc HTTP/1.1\r\nHost: " + host + "\r\nOrigin: http://lab-portal.example:8080\r\nAccess-Control-Request-Method: POST\r\n");
  EXPECT_EQ(r.status, 204);
  EXPECT_NE(r.headers.find("Access-Control-Allow-Origin: http://lab-portal.example:8080"), std::string::npos) << r.headers;
  const auto upgrade = [&](const std::string& origin) {
    return raw_http(port, "GET /ws HTTP/1.1\r\nHost: " + host + "\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                          "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n" +
                              (origin.empty() ? "" : "Origin: " + origin + "\r\n"))
        .status;
  };
  EXPECT_EQ(upgrade("http://evil.example"), 403);
  EXPECT_EQ(upgrade("null"), 403);
  EXPECT_EQ(upgrade("http://" + host), 101);
  EXPECT_EQ(upgrade("http://lab-portal.example:8080"), 101);
  EXPECT_EQ(upgrade(""), 101);  // not a browser
  EXPECT_GE(net_stats(g)["refused_origin"].get<int>(), 3);
  EXPECT_GE(net_stats(g)["refused_content_type"].get<int>(), 2);
}

TEST(Hostile, RevokingATokenEndsItsLiveSessions) {
  TempDir dir;
  Goniod g(dir.path, mock_config({}));
  auto admin = g.unix_conn();
  const auto token = admin.call("auth.create_token", {{"name", "visitor"}, {"role", "technician"}})["token"].get<std::string>();
  const auto other = admin.call("auth.create_token", {{"name", "staff"}, {"role", "viewer"}})["token"].get<std::string>();
  auto tcp = g.tcp_conn();
  tcp.call("auth.login", {{"token", token}});
  tcp.call("subscribe", {{"topics", {"alerts"}}});
  WebSocket ws(g.http_port(), token);
  ASSERT_EQ(ws.status, 101);
  EXPECT_TRUE(ws.call("auth.whoami").contains("result"));
  auto bystander = g.tcp_conn();
  bystander.call("auth.login", {{"token", other}});
  admin.call("auth.revoke_token", {{"name", "visitor"}});
  EXPECT_TRUE(tcp.closed_by_peer(10s));
  EXPECT_TRUE(ws.closed_by_peer());
  EXPECT_EQ(http(g.http_port(), "POST", "/rpc", R"({"jsonrpc":"2.0","id":1,"method":"auth.whoami"})", token).status, 401);
  EXPECT_TRUE(bystander.request("auth.whoami").contains("result"));
  EXPECT_GE(net_stats(g)["revoked_sessions_ended"].get<int>(), 2);
}

TEST(Hostile, NonAdminsSeeOnlyTheWebhooksHost) {
  TempDir dir;
  MockOptions o;
  o.extra = "[webhook]\nurl = \"http://127.0.0.1:9/hooks/s3cr3t?key=abc\"\nretries = 0\n";
  Goniod g(dir.path, mock_config(o));
  auto admin = g.unix_conn();
  EXPECT_EQ(admin.call("system.info")["webhook"]["url"], "http://127.0.0.1:9/hooks/s3cr3t?key=abc");
  const auto token = admin.call("auth.create_token", {{"name", "v"}, {"role", "viewer"}})["token"].get<std::string>();
  auto viewer = g.tcp_conn();
  viewer.call("auth.login", {{"token", token}});
  const auto info = viewer.call("system.info");
  EXPECT_EQ(info["webhook"]["url"], "http://127.0.0.1:9");
  EXPECT_EQ(info.dump().find("s3cr3t"), std::string::npos);
}

TEST(Hostile, TheFaultLatchSurvivesACrash) {
  TempDir dir;
  MockOptions o;
  o.faults = "garbage_at_point = 2";
  Goniod g(dir.path, mock_config(o));
  std::int64_t faulted = 0, next = 0;
  {
    auto c = g.unix_conn();
    faulted = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=0:30:10"}}});
    ASSERT_EQ(wait_state(c, faulted, {"paused", "completed"})["state"], "paused");
    next = c.call("scan.submit", json{{"sample", "tile"}, {"geometries", {"45as15"}}})["id"].get<std::int64_t>();
  }
  EXPECT_EQ(g.stop(SIGKILL), 128 + SIGKILL);
  g.start();
  auto c = g.unix_conn();
  const auto st = c.call("instrument.status");
  EXPECT_TRUE(st["fault_latched"].get<bool>()) << st.dump();
  EXPECT_EQ(st["state"], "fault");
  // The queued scan does not move the arms while latched.
  std::this_thread::sleep_for(1500ms);
  EXPECT_EQ(c.call("scan.get", json{{"scan", next}})["state"], "queued");
  EXPECT_EQ(c.call("scan.get", json{{"scan", faulted}})["state"], "paused");
  // A technician resets the instrument: the latch is acknowledged and stays cleared across a
  // restart. (Resuming would meet the mock's scripted fault again: its count restarts.)
  EXPECT_FALSE(c.call("instrument.reset")["fault_latched"].get<bool>());
  c.call("scan.cancel", json{{"scan", faulted}});
  EXPECT_EQ(wait_state(c, next, {"completed"})["state"], "completed");
  EXPECT_TRUE(c.call("alert.list", json{{"acknowledged", false}, {"severity", "critical"}}).empty());
  EXPECT_EQ(g.stop(SIGTERM), 0);
  g.start();
  EXPECT_FALSE(g.unix_conn().call("instrument.status")["fault_latched"].get<bool>());
}

TEST(Hostile, ExportsComeInChunksThatMakeTheWholeFile) {
  TempDir dir;
  Goniod g(dir.path, mock_config({}));
  auto c = g.unix_conn();
  const auto id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=0:40:10"}}, {"wavelengths", "400:700:100"}});
  ASSERT_EQ(wait_state(c, id, {"completed"})["state"], "completed");
  const auto collect = [&](const std::string& format, std::size_t limit) {
    std::string all;
    json off = 0;
    int chunks = 0;
    while (!off.is_null()) {
      const auto r = c.call("scan.export", json{{"scan", id}, {"format", format}, {"offset", off}, {"limit", limit}});
      all += r["content"].get<std::string>();
      off = r["next_offset"];
      ++chunks;
    }
    return std::make_pair(all, chunks);
  };
  const auto [csv, csv_chunks] = collect("csv", 2);
  EXPECT_EQ(csv_chunks, 3);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 2 + 5 * 4);  // header lines + points × channels
  const auto whole = c.call("scan.export", json{{"scan", id}, {"format", "csv"}})["content"].get<std::string>();
  EXPECT_EQ(csv.substr(csv.find('\n')), whole.substr(whole.find('\n')));  // but the export time
  const auto [js, js_chunks] = collect("json", 2);
  const auto doc = json::parse(js);
  EXPECT_EQ(doc["points"].size(), 5u);
  EXPECT_EQ(doc["scan"]["id"], id);
  // A table is the whole scan: no paging, and a limit that names its field.
  auto r = c.request("scan.export", json{{"scan", id}, {"format", "bsdf"}, {"offset", 2}});
  EXPECT_EQ(r["error"]["data"]["field"], "offset");
  r = c.request("scan.export", json{{"scan", id}, {"format", "csv"}, {"limit", 100000}});
  EXPECT_EQ(r["error"]["code"], -32602);
  EXPECT_EQ(r["error"]["data"]["field"], "limit");
}

}  // namespace
}  // namespace gonio::test

namespace gonio::test {
namespace {

TEST(Hostile, BsdfFilesComeOnlyFromTheDataDirectory) {
  TempDir dir;
  Goniod g(dir.path, mock_config({}));
  const auto data = dir.path / "data";
  fs::create_directories(data / "sub");
  std::ofstream(data / "sub" / "refl.csv") << "400,0.5\n700,0.6\n";
  fs::create_symlink(data / "sub" / "refl.csv", data / "link.csv");
  ::mkfifo((data / "fifo.csv").c_str(), 0600);
  auto c = g.unix_conn();
  const auto create = [&](const std::string& name, const std::string& bsdf) {
    return c.request("sample.create", json{{"name", name}, {"bsdf", bsdf}});
  };
  const auto ok = create("ok", "lambert:albedo=@sub/refl.csv");
  ASSERT_TRUE(ok.contains("result")) << ok.dump();
  EXPECT_NE(ok["result"]["bsdf"].get<std::string>().find((data / "sub" / "refl.csv").string()), std::string::npos);
  for (const auto& bad : {"lambert:albedo=@../goniod.db", "lambert:albedo=@/etc/passwd", "lambert:albedo=@link.csv",
                          "lambert:albedo=@fifo.csv", "lambert:albedo=@sub", "lambert:albedo=@sub/refl.csv,x/../../../etc/passwd",
                          "lambert:albedo=@sub/../sub/refl.csv", "@nosuch.ssdd"}) {
    const auto r = create("bad", bad);
    EXPECT_EQ(r["error"]["code"], -32602) << bad << ": " << r.dump();
    EXPECT_EQ(r["error"]["data"]["field"], "bsdf") << bad;
  }
  const auto p = c.request("twin.predict", json{{"bsdf", "lambert:albedo=@/etc/hostname"}, {"geometries", {"45as15"}}});
  EXPECT_EQ(p["error"]["data"]["field"], "bsdf") << p.dump();
}

}  // namespace
}  // namespace gonio::test

namespace gonio::test {
namespace {

// auth.whoami over goniod.sock from a child process running as `uid`:`gid` (needs root).
json whoami_as(const Goniod& g, uid_t uid, gid_t gid) {
  int fds[2];
  if (::pipe(fds) != 0) throw std::runtime_error("pipe");
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    std::string out = "{}";
    if (::setgroups(0, nullptr) == 0 && ::setgid(gid) == 0 && ::setuid(uid) == 0) {
      try {
        auto c = g.unix_conn();
        out = c.request("auth.whoami").dump();
      } catch (const std::exception& e) {
        out = json{{"connect", e.what()}}.dump();
      }
    }
    (void)!::write(fds[1], out.data(), out.size());
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string text;
  char b[4096];
  for (ssize_t n; (n = ::read(fds[0], b, sizeof b)) > 0;) text.append(b, static_cast<std::size_t>(n));
  ::close(fds[0]);
  ::waitpid(pid, nullptr, 0);
  return json::parse(text);
}

TEST(Hostile, UnixPeersGetTheRoleOfTheirUidAndGroups) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to connect as other users";
  TempDir dir;
  MockOptions o;
  o.extra = "[auth.unix]\nviewer_uids = [65533]\ntechnician_gids = [65532]\n";
  Goniod g(dir.path, mock_config(o));
  ::chmod(dir.path.c_str(), 0755);
  ::chmod((dir.path / "goniod.sock").c_str(), 0666);  // let the test's other users in
  EXPECT_EQ(whoami_as(g, 65533, 65533)["result"]["role"], "viewer");
  EXPECT_EQ(whoami_as(g, 65531, 65532)["result"]["role"], "technician");
  EXPECT_EQ(whoami_as(g, 65534, 65534)["error"]["code"], -32000);  // no role: log in first
  EXPECT_EQ(g.unix_conn().call("auth.whoami")["role"], "admin");  // root
}

}  // namespace
}  // namespace gonio::test
