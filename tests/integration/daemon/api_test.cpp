// The API over real sockets: every method with bad params, and the auth matrix over Unix,
// NDJSON TCP, HTTP and WebSocket.
#include <sys/stat.h>

#include <gtest/gtest.h>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

struct BadCall {
  std::string method;
  json params;
  int code;
  std::string field;  // error.data.field must start with this
};

TEST(Api, EveryMethodRejectsBadParamsNamingTheField) {
  TempDir dir;
  Goniod g(dir.path, mock_config({}));
  auto c = g.unix_conn();
  c.call("sample.create", json{{"name", "s"}, {"bsdf", kTrueSample}});
  const auto scan = c.call("scan.submit", json{{"sample", "s"}, {"geometries", {"45as15"}}})["id"];
  const std::vector<BadCall> cases = {
      {"rpc.discover", {{"x", 1}}, -32602, "x"},
      {"auth.login", json::object(), -32602, "token"},
      {"auth.login", {{"token", 5}}, -32602, "token"},
      {"auth.login", {{"token", "wrong"}}, -32000, "token"},
      {"auth.whoami", {{"x", 1}}, -32602, "x"},
      {"auth.create_token", {{"name", "n"}, {"role", "god"}}, -32602, "role"},
      {"auth.create_token", {{"name", "has space"}, {"role", "viewer"}}, -32602, "name"},
      {"auth.list_tokens", {{"x", 1}}, -32602, "x"},
      {"auth.revoke_token", json::object(), -32602, "name"},
      {"auth.revoke_token", {{"name", "nobody"}}, -32002, "name"},
      {"system.info", {{"verbose", true}}, -32602, "verbose"},
      {"system.audit", {{"limit", 5000}}, -32602, "limit"},
      {"instrument.status", {{"x", 1}}, -32602, "x"},
      {"instrument.home", {{"axes", {"elbow"}}}, -32602, "axes[0]"},
      {"instrument.move", json::object(), -32602, "params"},
      {"instrument.move", {{"incidence", "high"}}, -32602, "incidence"},
      {"instrument.move", {{"incidence", 89}}, -32007, "incidence"},
      {"instrument.stop", {{"now", 1}}, -32602, "now"},
      {"instrument.reset", {{"x", 1}}, -32602, "x"},
      {"sample.create", {{"name", "bad name"}}, -32602, "name"},
      {"sample.create", {{"name", "ok"}, {"tolerance", 5}}, -32602, "tolerance"},
      {"sample.create", {{"name", "ok"}, {"bsdf", "lambert:albedo=7"}}, -32602, "bsdf"},
      {"sample.create", {{"name", "s"}}, -32003, "name"},
      {"sample.get", json::object(), -32602, "sample"},
      {"sample.get", {{"sample", true}}, -32602, "sample"},
      {"sample.get", {{"sample", 99}}, -32002, "sample"},
      {"sample.list", {{"offset", -1}}, -32602, "offset"},
      {"scan.submit", {{"sample", "nosuch"}, {"geometries", {"45as15"}}}, -32002, "sample"},
      {"scan.submit", {{"sample", "s"}, {"geometries", {"45as15"}}, {"repeats", 0}}, -32602, "repeats"},
      {"scan.submit", {{"sample", "s"}, {"geometries", {"45as15", "95as0"}}}, -32602, "geometries[1]"},
      {"scan.submit", {{"sample", "s"}, {"grids", {"in=45;out=-89:89:1"}}}, -32006, "geometries[0]"},
      {"scan.submit", {{"sample", "s"}, {"geometries", {"45as15"}}, {"wavelengths", "300:900:10"}}, -32006, "wavelengths"},
      {"scan.submit", {{"sample", "s"}, {"geometries", {"45as15"}}, {"priority", 1000}}, -32602, "priority"},
      {"scan.get", {{"scan", 0}}, -32602, "scan"},
      {"scan.get", {{"scan", "x"}}, -32602, "scan"},
      {"scan.get", {{"scan", 999}}, -32002, "scan"},
      {"scan.list", {{"state", "sleeping"}}, -32602, "state"},
      {"scan.cancel", {{"scan", -1}}, -32602, "scan"},
      {"scan.pause", {{"scan", scan}, {"reason", 3}}, -32602, "reason"},
      {"scan.resume", json::object(), -32602, "scan"},
      {"scan.points", {{"scan", scan}, {"limit", 5000}}, -32602, "limit"},
      {"scan.export", {{"scan", scan}, {"format", "xlsx"}}, -32602, "format"},
      {"queue.status", {{"x", 1}}, -32602, "x"},
      {"queue.reorder", {{"scan", scan}}, -32602, "position"},
      {"alert.list", {{"severity", "loud"}}, -32602, "severity"},
      {"alert.ack", {{"alert", 0}}, -32602, "alert"},
      {"alert.ack", {{"alert", 12345}}, -32002, "alert"},
      {"twin.predict", {{"geometries", {"45as15"}}}, -32602, "bsdf"},
      {"twin.predict", {{"bsdf", "lambert:albedo=0.5"}, {"geometries", {"45as15"}}, {"rel_se", 2}}, -32602, "rel_se"},
      {"twin.predict", {{"bsdf", "nope:x=1"}, {"geometries", {"45as15"}}}, -32602, "bsdf"},
      {"subscribe", {{"topics", {"weather"}}}, -32602, "topics[0]"},
      {"subscribe", {{"topics", json::array()}}, -32602, "topics"},
      {"unsubscribe", {{"topics", "all"}}, -32602, "topics"},
  };
  std::set<std::string> covered;
  for (const auto& bc : cases) {
    const auto r = c.request(bc.method, bc.params);
    ASSERT_TRUE(r.contains("error")) << bc.method << " " << bc.params.dump() << " -> " << r.dump();
    EXPECT_EQ(r["error"]["code"], bc.code) << bc.method << " " << r.dump();
    const auto field = r["error"]["data"].value("field", std::string());
    EXPECT_TRUE(field.starts_with(bc.field)) << bc.method << ": field '" << field << "', expected '" << bc.field << "'";
    EXPECT_FALSE(r["error"]["message"].get<std::string>().empty());
    covered.insert(bc.method);
  }
  // Every documented method has a case.
  for (const auto& m : c.call("rpc.discover")["methods"])
    EXPECT_TRUE(covered.contains(m["name"].get<std::string>())) << m["name"];
}

TEST(Api, AuthMatrix) {
  TempDir dir;
  Goniod g(dir.path, mock_config({}));
  auto admin = g.unix_conn();
  // The local gates: socket 0660, admin token 0600.
  struct stat st {};
  ASSERT_EQ(::stat((dir.path / "goniod.sock").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0660u);
  ASSERT_EQ(::stat((dir.path / "admin.token").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_EQ(admin.call("auth.whoami")["role"], "admin");
  const auto viewer = admin.call("auth.create_token", json{{"name", "v"}, {"role", "viewer"}})["token"].get<std::string>();
  const auto tech = admin.call("auth.create_token", json{{"name", "t"}, {"role", "technician"}})["token"].get<std::string>();
  const auto root = g.admin_token();
  admin.call("sample.create", json{{"name", "s"}, {"bsdf", kTrueSample}});
  const auto code = [](const json& r) { return r.contains("error") ? r["error"]["code"].get<int>() : 0; };

  // NDJSON TCP: nothing but rpc.discover and auth.login before auth.login.
  {
    auto c = g.tcp_conn();
    EXPECT_EQ(code(c.request("system.info")), -32000);
    EXPECT_EQ(code(c.request("rpc.discover")), 0);
    EXPECT_EQ(code(c.request("auth.login", json{{"token", "guess"}})), -32000);
    EXPECT_EQ(code(c.request("system.info")), -32000);
    EXPECT_EQ(code(c.request("auth.login", json{{"token", viewer}})), 0);
    EXPECT_EQ(code(c.request("system.info")), 0);
    EXPECT_EQ(code(c.request("scan.points", json{{"scan", 1}})), -32002);  // allowed, just absent
    EXPECT_EQ(code(c.request("scan.submit", json{{"sample", "s"}, {"geometries", {"45as15"}}})), -32001);
    EXPECT_EQ(code(c.request("alert.ack", json{{"alert", 1}})), -32001);
    EXPECT_EQ(code(c.request("instrument.stop")), -32001);
    EXPECT_EQ(code(c.request("auth.create_token", json{{"name", "x"}, {"role", "admin"}})), -32001);
  }
  {
    auto c = g.tcp_conn();
    c.call("auth.login", json{{"token", tech}});
    EXPECT_EQ(code(c.request("scan.submit", json{{"sample", "s"}, {"geometries", {"45as15"}}})), 0);
    EXPECT_EQ(code(c.request("auth.list_tokens")), -32001);
    EXPECT_EQ(c.call("auth.whoami")["name"], "t");
  }
  {
    auto c = g.tcp_conn();
    c.call("auth.login", json{{"token", root}});
    EXPECT_EQ(code(c.request("auth.list_tokens")), 0);
    EXPECT_EQ(code(c.request("system.audit")), 0);
  }
  // HTTP POST /rpc: the Authorization header.
  const auto body = [](const std::string& m) { return json{{"jsonrpc", "2.0"}, {"id", 1}, {"method", m}}.dump(); };
  auto r = http(g.http_port(), "POST", "/rpc", body("rpc.discover"));
  EXPECT_EQ(r.status, 200);
  EXPECT_TRUE(json::parse(r.body).contains("result"));
  r = http(g.http_port(), "POST", "/rpc", body("system.info"));
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(json::parse(r.body)["error"]["code"], -32000);
  r = http(g.http_port(), "POST", "/rpc", body("system.info"), "wrong-token");
  EXPECT_EQ(r.status, 401);
  EXPECT_NE(r.headers.find("WWW-Authenticate: Bearer"), std::string::npos) << r.headers;
  r = http(g.http_port(), "POST", "/rpc", body("system.info"), viewer);
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(json::parse(r.body)["result"]["you"]["role"], "viewer");
  EXPECT_EQ(json::parse(http(g.http_port(), "POST", "/rpc", body("instrument.stop"), viewer).body)["error"]["code"], -32001);
  EXPECT_EQ(json::parse(http(g.http_port(), "POST", "/rpc", body("auth.list_tokens"), root).body)["result"].size(), 3u);
  EXPECT_EQ(http(g.http_port(), "GET", "/rpc", "", viewer).status, 405);
  EXPECT_EQ(http(g.http_port(), "POST", "/elsewhere", body("system.info"), viewer).status, 404);
  EXPECT_EQ(http(g.http_port(), "POST", "/rpc", R"({"jsonrpc":"2.0","method":"system.info"})", viewer).status, 204);
  // HTTP cannot subscribe: nothing could reach it.
  EXPECT_EQ(json::parse(http(g.http_port(), "POST", "/rpc", body("subscribe"), viewer).body)["error"]["code"], -32008);

  // WebSocket: the header at the upgrade, or auth.login first.
  {
    WebSocket ws(g.http_port(), viewer);
    EXPECT_EQ(ws.status, 101);
    EXPECT_FALSE(ws.call("system.info").contains("error"));
    EXPECT_EQ(ws.call("sample.create", json{{"name", "w"}})["error"]["code"], -32001);
  }
  {
    WebSocket ws(g.http_port());
    EXPECT_EQ(ws.status, 101);
    EXPECT_EQ(ws.call("system.info")["error"]["code"], -32000);
    EXPECT_FALSE(ws.call("auth.login", json{{"token", tech}}).contains("error"));
    EXPECT_EQ(ws.call("auth.whoami")["result"]["role"], "technician");
  }
  EXPECT_EQ(WebSocket(g.http_port(), "wrong").status, 401);
  // Revoked tokens stop working.
  admin.call("auth.revoke_token", json{{"name", "v"}});
  EXPECT_EQ(http(g.http_port(), "POST", "/rpc", body("system.info"), viewer).status, 401);
}

}  // namespace
}  // namespace gonio::test
