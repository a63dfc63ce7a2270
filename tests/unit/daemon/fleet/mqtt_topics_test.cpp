// MQTT topics and routing (daemon/src/fleet/mqtt_topics.cpp): which notification goes to which
// topic, retained or not.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/daemon/fleet/mqtt.hpp"

namespace gonio::daemon {
namespace {

using nlohmann::json;

TEST(MqttTopics, NamesAndRouting) {
  MqttTopics t{"lab/gonio", "gcms-a"};
  EXPECT_EQ(t.state(), "lab/gonio/gcms-a/state");
  EXPECT_EQ(t.scan(12), "lab/gonio/gcms-a/scan/12");
  EXPECT_EQ(t.progress(12), "lab/gonio/gcms-a/scan/12/progress");
  EXPECT_EQ(t.point(12), "lab/gonio/gcms-a/scan/12/point");
  EXPECT_EQ(t.alert(), "lab/gonio/gcms-a/alert");

  const auto state = mqtt_route(t, "instrument.state", R"({"state":"idle"})", std::nullopt);
  ASSERT_TRUE(state);
  EXPECT_EQ(state->topic, t.state());
  EXPECT_TRUE(state->retain);
  EXPECT_EQ(state->payload, R"({"state":"idle"})");  // the notification's params, unchanged

  const auto sc = mqtt_route(t, "scan.state", R"({"scan":12,"state":"running","reason":""})", std::nullopt);
  ASSERT_TRUE(sc);
  EXPECT_EQ(sc->topic, t.scan(12));
  EXPECT_TRUE(sc->retain);
  const auto pr = mqtt_route(t, "scan.progress", "{}", 12);
  ASSERT_TRUE(pr);
  EXPECT_EQ(pr->topic, t.progress(12));
  EXPECT_TRUE(pr->retain);
  const auto pt = mqtt_route(t, "scan.point", R"({"scan_id":12,"index":0})", std::nullopt);
  ASSERT_TRUE(pt);
  EXPECT_EQ(pt->topic, t.point(12));
  EXPECT_FALSE(pt->retain);
  const auto al = mqtt_route(t, "alert", R"({"id":1})", 12);
  ASSERT_TRUE(al);
  EXPECT_EQ(al->topic, t.alert());
  EXPECT_FALSE(al->retain);

  EXPECT_FALSE(mqtt_route(t, "something.else", "{}", std::nullopt));
  EXPECT_FALSE(mqtt_route(t, "scan.point", R"({"no":"scan"})", std::nullopt));
  EXPECT_EQ(json::parse(kMqttOffline)["state"], "offline");
}

}  // namespace
}  // namespace gonio::daemon
