// Subscriptions: topics, scan filters, full queues, sessions that are gone.
#include <gtest/gtest.h>

#include "gonio/daemon/rpc/hub.hpp"

namespace gonio::daemon {
namespace {

using nlohmann::json;

// A session that records what it is sent, refusing after `capacity` messages.
class Recorder final : public rpc::Session {
 public:
  explicit Recorder(std::size_t capacity = 100) : rpc::Session("test", "peer", true), capacity_(capacity) {}
  bool push(std::shared_ptr<const std::string> m) override {
    if (got.size() >= capacity_) return false;
    got.push_back(json::parse(*m));
    return true;
  }
  std::vector<json> got;

 private:
  std::size_t capacity_;
};

TEST(Hub, DeliversByTopicAndScan) {
  Hub hub;
  auto all = std::make_shared<Recorder>();
  auto one = std::make_shared<Recorder>();
  hub.subscribe(all, {Topic::progress, Topic::alerts}, std::nullopt);
  hub.subscribe(one, {Topic::progress, Topic::alerts}, 2);
  hub.publish(Topic::progress, "scan.progress", json{{"scan", 1}}, 1);
  hub.publish(Topic::progress, "scan.progress", json{{"scan", 2}}, 2);
  hub.publish(Topic::alerts, "alert", json{{"id", 5}}, 1);  // alerts ignore the scan filter
  hub.publish(Topic::points, "scan.point", json::object(), 2);  // nobody asked for points
  ASSERT_EQ(all->got.size(), 3u);
  ASSERT_EQ(one->got.size(), 2u);
  EXPECT_EQ(one->got[0]["method"], "scan.progress");
  EXPECT_EQ(one->got[0]["params"]["scan"], 2);
  EXPECT_EQ(one->got[0]["jsonrpc"], "2.0");
  EXPECT_FALSE(one->got[0].contains("id"));  // a notification
  EXPECT_EQ(one->got[1]["method"], "alert");
}

TEST(Hub, UnsubscribeAndForgottenSessions) {
  Hub hub;
  auto s = std::make_shared<Recorder>();
  hub.subscribe(s, {Topic::state, Topic::points}, std::nullopt);
  EXPECT_EQ(hub.unsubscribe(s->id(), {Topic::points}), std::set<Topic>{Topic::state});
  hub.publish(Topic::points, "scan.point", json::object());
  EXPECT_TRUE(s->got.empty());
  EXPECT_EQ(hub.sessions(), 1u);
  s.reset();  // the connection is gone
  hub.publish(Topic::state, "instrument.state", json::object());
  EXPECT_EQ(hub.sessions(), 0u);
}

TEST(Hub, CountsRefusedNotifications) {
  Hub hub;
  auto s = std::make_shared<Recorder>(1);
  hub.subscribe(s, {Topic::alerts}, std::nullopt);
  for (int i = 0; i < 3; ++i) hub.publish(Topic::alerts, "alert", json{{"id", i}});
  EXPECT_EQ(s->got.size(), 1u);
  EXPECT_EQ(hub.dropped(), 2u);
  EXPECT_THROW(parse_enum<Topic>("weather", "topics[0]"), Error);
}

}  // namespace
}  // namespace gonio::daemon
