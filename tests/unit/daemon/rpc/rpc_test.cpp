// JSON-RPC 2.0 semantics of the dispatcher (independent of any transport).
#include <gtest/gtest.h>

#include "gonio/daemon/rpc/fair_queue.hpp"
#include "gonio/daemon/rpc/rpc.hpp"

namespace gonio::daemon::rpc {
namespace {

using nlohmann::json;

class TestSession final : public Session {
 public:
  explicit TestSession(Role role) : Session("test", "peer", true) {
    Principal p;
    p.name = "tester";
    p.role = role;
    set_principal(p);
  }
  bool push(std::shared_ptr<const std::string>) override { return true; }
  void hang_up() { mark_gone(); }
};

class DispatcherTest : public ::testing::Test {
 protected:
  DispatcherTest() : d_(nullptr) {
    d_.add(Method{"echo", Role::viewer, false, [](Call& c) { return c.params; }});
    d_.add(Method{"open", Role::none, false, [](Call&) { return json("ok"); }});
    d_.add(Method{"admin.only", Role::admin, false, [](Call&) { return json(true); }});
    d_.add(Method{"fail", Role::viewer, false, [](Call& c) -> json {
                    const auto what = c.params.value("errc", std::string("out_of_range"));
                    throw Error(errc_from_id(what), "failed on purpose", "the.field");
                  }});
    d_.add(Method{"boom", Role::viewer, false, [](Call&) -> json { throw std::runtime_error("bug"); }});
  }

  // Handles `text` as `role`; returns the parsed response ("" when none).
  json call(const std::string& text, Role role = Role::viewer) {
    std::string out = "<no reply>";
    d_.handle(text, std::make_shared<TestSession>(role), [&](std::string r) { out = std::move(r); });
    EXPECT_NE(out, "<no reply>") << "reply must be called exactly once";
    return out.empty() ? json() : json::parse(out);
  }

  Dispatcher d_;
};

TEST_F(DispatcherTest, AnswersARequestWithItsId) {
  const auto r = call(R"({"jsonrpc":"2.0","id":"a1","method":"echo","params":{"x":1}})");
  EXPECT_EQ(r["jsonrpc"], "2.0");
  EXPECT_EQ(r["id"], "a1");
  EXPECT_EQ(r["result"]["x"], 1);
  EXPECT_FALSE(r.contains("error"));
  EXPECT_EQ(call(R"({"jsonrpc":"2.0","id":7,"method":"echo"})")["result"], json::object());
}

TEST_F(DispatcherTest, StandardErrorCodes) {
  EXPECT_EQ(call("{not json")["error"]["code"], -32700);
  EXPECT_EQ(call("[1E400]")["error"]["code"], -32700);  // a number no double holds: not a throw
  EXPECT_TRUE(call("{not json")["id"].is_null());
  EXPECT_EQ(call("42")["error"]["code"], -32600);
  EXPECT_EQ(call(R"({"jsonrpc":"1.0","id":1,"method":"echo"})")["error"]["code"], -32600);
  EXPECT_EQ(call(R"({"jsonrpc":"2.0","id":1,"method":5})")["error"]["code"], -32600);
  EXPECT_EQ(call(R"({"jsonrpc":"2.0","id":{},"method":"echo"})")["error"]["code"], -32600);
  EXPECT_EQ(call(R"({"jsonrpc":"2.0","id":1,"method":"echo","params":3})")["error"]["code"], -32600);
  EXPECT_EQ(call(R"({"jsonrpc":"2.0","id":1,"method":"echo","extra":1})")["error"]["code"], -32600);
  const auto nf = call(R"({"jsonrpc":"2.0","id":1,"method":"nope"})");
  EXPECT_EQ(nf["error"]["code"], -32601);
  EXPECT_EQ(nf["id"], 1);
  EXPECT_EQ(call(R"({"jsonrpc":"2.0","id":1,"method":"echo","params":[1,2]})")["error"]["code"], -32602);
  const auto ip = call(R"({"jsonrpc":"2.0","id":1,"method":"fail"})");
  EXPECT_EQ(ip["error"]["code"], -32602);
  EXPECT_EQ(ip["error"]["data"]["field"], "the.field");
  EXPECT_EQ(ip["error"]["data"]["errc"], "out_of_range");
  EXPECT_EQ(call(R"({"jsonrpc":"2.0","id":1,"method":"boom"})")["error"]["code"], -32603);
  std::string deep(100, '[');
  deep += std::string(100, ']');
  EXPECT_EQ(call(deep)["error"]["code"], -32600);
}

TEST_F(DispatcherTest, ServerErrorsMapFromErrc) {
  const auto code = [&](const char* errc) {
    return call(json{{"jsonrpc", "2.0"}, {"id", 1}, {"method", "fail"}, {"params", {{"errc", errc}}}}.dump())["error"]["code"]
        .get<int>();
  };
  EXPECT_EQ(code("not_found"), code::not_found);
  EXPECT_EQ(code("invalid_state"), code::invalid_state);
  EXPECT_EQ(code("busy"), code::instrument_busy);
  EXPECT_EQ(code("timeout"), code::instrument_fault);
  EXPECT_EQ(code("disconnected"), code::instrument_fault);
  EXPECT_EQ(code("plan_rejected"), code::plan_rejected);
  EXPECT_EQ(code("limit_violation"), code::limit_violation);
  EXPECT_EQ(code("unsupported"), code::unsupported);
  EXPECT_EQ(code("unauthorized"), code::unauthorized);
  for (int c : {code::unauthorized, code::forbidden, code::not_found, code::invalid_state,
                code::instrument_busy, code::instrument_fault, code::plan_rejected,
                code::limit_violation, code::unsupported, code::io_error, code::overloaded})
    EXPECT_TRUE(c <= -32000 && c >= -32099) << c;
}

TEST_F(DispatcherTest, NotificationsAreNeverAnswered) {
  EXPECT_TRUE(call(R"({"jsonrpc":"2.0","method":"echo"})").is_null());
  EXPECT_TRUE(call(R"({"jsonrpc":"2.0","method":"nope"})").is_null());
  EXPECT_TRUE(call(R"({"jsonrpc":"2.0","method":"fail"})").is_null());
}

TEST_F(DispatcherTest, BatchesAnswerInOrderWithoutNotifications) {
  const auto r = call(R"([{"jsonrpc":"2.0","id":1,"method":"echo","params":{"n":1}},
                          {"jsonrpc":"2.0","method":"echo"},
                          {"jsonrpc":"2.0","id":2,"method":"nope"},
                          17])");
  ASSERT_TRUE(r.is_array());
  ASSERT_EQ(r.size(), 3u);
  EXPECT_EQ(r[0]["result"]["n"], 1);
  EXPECT_EQ(r[1]["error"]["code"], -32601);
  EXPECT_EQ(r[2]["error"]["code"], -32600);
  EXPECT_EQ(call("[]")["error"]["code"], -32600);  // an empty batch is one error, not an array
  EXPECT_TRUE(call(R"([{"jsonrpc":"2.0","method":"echo"},{"jsonrpc":"2.0","method":"echo"}])").is_null());
}

TEST_F(DispatcherTest, RolesGateMethods) {
  EXPECT_EQ(call(R"({"jsonrpc":"2.0","id":1,"method":"echo"})", Role::none)["error"]["code"], code::unauthorized);
  EXPECT_EQ(call(R"({"jsonrpc":"2.0","id":1,"method":"open"})", Role::none)["result"], "ok");
  EXPECT_EQ(call(R"({"jsonrpc":"2.0","id":1,"method":"admin.only"})", Role::technician)["error"]["code"],
            code::forbidden);
  EXPECT_EQ(call(R"({"jsonrpc":"2.0","id":1,"method":"admin.only"})", Role::admin)["result"], true);
}

TEST(Dispatcher, BlockingMethodsRunOnTheExecutor) {
  std::vector<std::function<void()>> queued;
  Dispatcher d([&](std::uint64_t, std::function<void()> f) { queued.push_back(std::move(f)); });
  d.add(Method{"slow", Role::viewer, true, [](Call&) { return json(1); }});
  std::string out;
  bool replied = false;
  d.handle(R"([{"jsonrpc":"2.0","id":1,"method":"slow"},{"jsonrpc":"2.0","id":2,"method":"slow"}])",
           std::make_shared<TestSession>(Role::viewer), [&](std::string r) {
             replied = true;
             out = std::move(r);
           });
  EXPECT_FALSE(replied);  // nothing ran yet
  ASSERT_EQ(queued.size(), 2u);
  queued[1]();
  EXPECT_FALSE(replied);  // a batch answers when all of it is done
  queued[0]();
  ASSERT_TRUE(replied);
  const auto r = json::parse(out);
  EXPECT_EQ(r[0]["id"], 1);
  EXPECT_EQ(r[1]["id"], 2);
}

TEST(Dispatcher, ReadsOfAPeerThatHungUpAreNotDoneButCommandsAre) {
  std::vector<std::function<void()>> queued;
  Dispatcher d([&](std::uint64_t, std::function<void()> f) { queued.push_back(std::move(f)); });
  int reads = 0, commands = 0;
  d.add(Method{"read", Role::viewer, true, [&](Call&) { return json(++reads); }});
  d.add(Method{"command", Role::technician, true, [&](Call&) { return json(++commands); }});
  const auto session = std::make_shared<TestSession>(Role::technician);
  std::vector<std::string> replies;
  const auto reply = [&](std::string r) { replies.push_back(std::move(r)); };
  d.handle(R"({"jsonrpc":"2.0","id":1,"method":"read"})", session, reply);
  d.handle(R"([{"jsonrpc":"2.0","id":2,"method":"read"},{"jsonrpc":"2.0","id":3,"method":"command"}])", session, reply);
  d.handle(R"({"jsonrpc":"2.0","method":"command"})", session, reply);
  ASSERT_EQ(queued.size(), 4u);
  queued[0]();  // still connected: done
  session->hang_up();
  for (std::size_t i = 1; i < queued.size(); ++i) queued[i]();
  EXPECT_EQ(reads, 1);
  EXPECT_EQ(commands, 2);  // a command, in a batch or alone, runs whatever the connection does
  EXPECT_EQ(d.abandoned(), 1u);
  ASSERT_EQ(replies.size(), 3u);  // every message is still answered (to nobody) exactly once
  EXPECT_EQ(json::parse(replies[0])["result"], 1);
}

TEST(Dispatcher, AClientsBatchDoesNotStandBetweenAnotherClientAndItsAnswer) {
  FairQueue queue;
  Dispatcher d([&](std::uint64_t client, std::function<void()> f) { queue.push(client, std::move(f)); });
  std::vector<std::string> order;
  d.add(Method{"read", Role::viewer, true, [&](Call& c) {
                 order.push_back(c.params.value("who", std::string()));
                 return json(true);
               }});
  std::string batch = "[";
  for (int i = 0; i < 10; ++i)
    batch += (i ? "," : "") + json{{"jsonrpc", "2.0"}, {"id", i}, {"method", "read"}, {"params", {{"who", "flood"}}}}.dump();
  std::string flood_answer, answer;
  d.handle(batch + "]", std::make_shared<TestSession>(Role::viewer), [&](std::string r) { flood_answer = std::move(r); });
  d.handle(R"({"jsonrpc":"2.0","id":1,"method":"read","params":{"who":"technician"}})",
           std::make_shared<TestSession>(Role::viewer), [&](std::string r) { answer = std::move(r); });
  while (auto task = queue.pop()) task();
  ASSERT_EQ(order.size(), 11u);
  EXPECT_EQ(order[1], "technician");  // after one task of the client queued first, not after its ten
  EXPECT_EQ(json::parse(flood_answer).size(), 10u);
  EXPECT_EQ(json::parse(answer)["result"], true);
}

TEST(Dispatcher, BatchAnswersBeingAssembledStayWithinTheirBudget) {
  std::vector<std::function<void()>> queued;
  DispatchLimits limits;
  limits.max_building_bytes = 310u << 10;  // three answers of 100 KiB and their envelopes
  Dispatcher d([&](std::uint64_t, std::function<void()> f) { queued.push_back(std::move(f)); }, nullptr, limits);
  d.add(Method{"big", Role::viewer, true, [](Call&) { return json(std::string(100u << 10, 'x')); }});
  d.add(Method{"small", Role::viewer, true, [](Call&) { return json("ok"); }});
  const auto batch = [](std::initializer_list<const char*> methods) {
    std::string b = "[";
    int id = 0;
    for (const char* m : methods) {
      if (id) b += ',';
      b += json{{"jsonrpc", "2.0"}, {"id", id++}, {"method", m}}.dump();
    }
    return b + "]";
  };
  std::string a, b;
  d.handle(batch({"big", "big", "big"}), std::make_shared<TestSession>(Role::viewer), [&](std::string r) { a = std::move(r); });
  d.handle(batch({"big", "big", "small"}), std::make_shared<TestSession>(Role::viewer), [&](std::string r) { b = std::move(r); });
  ASSERT_EQ(queued.size(), 6u);
  queued[0]();  // a[0]
  queued[1]();  // a[1]
  queued[3]();  // b[0]: 300 KiB held, the budget
  EXPECT_GE(d.building_bytes(), 300u << 10);  // three answers held: no room for a fourth
  queued[4]();  // b[1] does not fit
  queued[5]();  // b[2] is small: always fits
  ASSERT_FALSE(b.empty());
  queued[2]();  // a[2]: b has gone, so it fits
  ASSERT_FALSE(a.empty());
  EXPECT_EQ(d.building_bytes(), 0u);  // all given back
  EXPECT_EQ(d.building_refused(), 1u);
  const auto ja = json::parse(a), jb = json::parse(b);
  for (const auto& e : ja) EXPECT_TRUE(e.contains("result")) << e.dump().substr(0, 200);
  EXPECT_TRUE(jb[0].contains("result"));
  EXPECT_EQ(jb[1]["error"]["code"], code::overloaded);
  EXPECT_EQ(jb[1]["id"], 1);
  EXPECT_NE(jb[1]["error"]["message"].get<std::string>().find("server.max_building_bytes"), std::string::npos);
  EXPECT_EQ(jb[2]["result"], "ok");
}

TEST(Dispatcher, BatchesAndValuesAreCountedBeforeParsing) {
  DispatchLimits limits;
  limits.max_batch = 3;
  limits.max_values = 50;
  Dispatcher d(nullptr, nullptr, limits);
  d.add(Method{"ping", Role::none, false, [](Call&) { return json(1); }});
  const auto run = [&](const std::string& text) {
    std::string out;
    const auto weight = d.handle(text, std::make_shared<TestSession>(Role::viewer), [&](std::string r) { out = std::move(r); });
    return std::make_pair(json::parse(out), weight);
  };
  const std::string ping = R"({"jsonrpc":"2.0","id":1,"method":"ping"})";
  auto [r, w] = run("[" + ping + "," + ping + "," + ping + "]");
  EXPECT_EQ(r.size(), 3u);
  EXPECT_EQ(w, 3u);  // a batch weighs its elements
  std::tie(r, w) = run("[" + ping + "," + ping + "," + ping + "," + ping + "]");
  EXPECT_EQ(r["error"]["code"], code::invalid_request);
  EXPECT_NE(r["error"]["message"].get<std::string>().find("server.max_batch = 3"), std::string::npos);
  EXPECT_EQ(w, 1u);
  std::tie(r, w) = run("[{},{},{},{}]");
  EXPECT_EQ(r["error"]["code"], code::invalid_request);
  std::string many = R"({"jsonrpc":"2.0","id":1,"method":"ping","params":{"x":[)";
  for (int i = 0; i < 60; ++i) many += (i ? ",0" : "0");
  std::tie(r, w) = run(many + "]}}");
  EXPECT_NE(r["error"]["message"].get<std::string>().find("JSON values"), std::string::npos) << r.dump();
  // Strings hide their brackets and commas.
  std::tie(r, w) = run(R"([{"jsonrpc":"2.0","id":"[,,,,{{{","method":"ping"}])");
  EXPECT_EQ(r[0]["id"], "[,,,,{{{");
}

TEST(Dispatcher, ABatchRunsAWindowAtATimeAndStaysWithinTheResponseLimit) {
  std::vector<std::function<void()>> queued;
  DispatchLimits limits;
  limits.batch_window = 2;
  limits.max_response_bytes = 200;
  Dispatcher d([&](std::uint64_t, std::function<void()> f) { queued.push_back(std::move(f)); }, nullptr, limits);
  d.add(Method{"slow", Role::viewer, true, [](Call& c) { return json(std::string(c.params.value("n", 1), 'x')); }});
  std::string batch = "[";
  for (int i = 0; i < 5; ++i)
    batch += (i ? "," : "") + json{{"jsonrpc", "2.0"}, {"id", i}, {"method", "slow"}, {"params", {{"n", i == 3 ? 150 : 10}}}}.dump();
  std::string out;
  d.handle(batch + "]", std::make_shared<TestSession>(Role::viewer), [&](std::string r) { out = std::move(r); });
  EXPECT_EQ(queued.size(), 2u);  // the window
  for (std::size_t i = 0; i < queued.size(); ++i) {  // each finished element lets the next start
    auto f = std::move(queued[i]);
    f();
  }
  EXPECT_EQ(queued.size(), 5u);
  ASSERT_FALSE(out.empty());
  const auto r = json::parse(out);
  ASSERT_EQ(r.size(), 5u);
  EXPECT_TRUE(r[0].contains("result"));
  EXPECT_EQ(r[3]["error"]["code"], code::unsupported);  // would pass 200 bytes: an error in its place
  EXPECT_EQ(r[3]["id"], 3);
  EXPECT_LE(out.size(), 200u + 400u);
}

// A result written as text is wrapped whether or not it left room for the envelope (one
// without room used to be read as a shared text that was not there).
TEST(Response, RawTextWithAndWithoutRoomForTheEnvelope) {
  const std::string want = R"({"jsonrpc":"2.0","result":{"a":1},"id":7})";
  std::string tight = R"({"a":1})";
  tight.shrink_to_fit();
  EXPECT_EQ(response_text(7, Result(RawJson(tight))), want);
  std::string roomy = R"({"a":1})";
  roomy.reserve(256);
  EXPECT_EQ(response_text(7, Result(RawJson(std::move(roomy)))), want);
  EXPECT_EQ(response_text(7, Result(RawJson({}, std::make_shared<const std::string>(R"({"a":1})")))), want);
}

}  // namespace
}  // namespace gonio::daemon::rpc
