// Modbus motion driver configuration: a full config reads back, and every unknown key,
// malformed value and out-of-range number is rejected naming its field.
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/drivers/modbus/modbus_motion.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/test/error_of.hpp"

namespace mb = gonio::drivers::modbus;
using gonio::Errc;
using gonio::Error;
using gonio::drivers::Axis;
using nlohmann::json;

namespace {

json base() {
  return json{
      {"links",
       {{"bus", {{"type", "rtu"}, {"device", "/dev/ttyUSB0"}, {"baud", 115200}, {"format", "8E1"}}},
        {"net", {{"type", "tcp"}, {"host", "192.0.2.10"}, {"port", 502}}}}},
      {"response_timeout_ms", 150},
      {"reconnect", {{"initial_ms", 20}, {"max_ms", 500}}},
      {"axes",
       {{"receive", {{"link", "bus"}, {"unit", 2}, {"steps_per_degree", 1000}}},
        {"incidence",
         {{"link", "bus"}, {"unit", 1}, {"steps_per_degree", -500}, {"zero_deg", 2}, {"speed_deg_s", 5}}},
        {"tilt", {{"link", "net"}, {"unit", 1}, {"steps_per_degree", 100},
                  {"register_map", {{"word_order", "low_first"}}}}}}}};
}

Error error_of(const json& j) {
  return gonio::test::error_of([&] { mb::MotionConfig::from_json(j); });
}

}  // namespace

TEST(MotionConfig, ReadsEveryPart) {
  const auto c = mb::MotionConfig::from_json(base());
  ASSERT_EQ(c.links.size(), 2u);
  ASSERT_EQ(c.axes.size(), 3u);
  EXPECT_EQ(c.axes[0].axis, Axis::incidence);  // sorted
  EXPECT_EQ(c.axes[1].axis, Axis::receive);
  EXPECT_EQ(c.axes[2].axis, Axis::tilt);
  EXPECT_EQ(c.axes[0].scale.steps_per_degree, -500);
  EXPECT_EQ(c.axes[0].scale.zero_deg, 2);
  EXPECT_EQ(c.axes[0].speed_deg_s, 5);
  EXPECT_EQ(c.axes[2].map.word_order, mb::WordOrder::low_first);
  EXPECT_EQ(c.axes[1].map, mb::RegisterMap::preset("az"));
  EXPECT_EQ(c.timing.response_timeout.count(), 150);
  EXPECT_EQ(c.timing.backoff_initial.count(), 20);
  const auto& bus = c.links[0].name == "bus" ? c.links[0] : c.links[1];
  EXPECT_EQ(bus.kind, mb::LinkConfig::Kind::rtu);
  EXPECT_EQ(bus.parity, 'E');
  EXPECT_EQ(bus.describe(), "rtu /dev/ttyUSB0 115200 8E1");
}

TEST(MotionConfig, SingleLinkNeedsNoLinkName) {
  const json j{{"links", {{"only", {{"type", "tcp"}, {"host", "127.0.0.1"}}}}},
               {"axes", {{"rotation", {{"unit", 3}, {"steps_per_degree", 10}}}}}};
  const auto c = mb::MotionConfig::from_json(j);
  EXPECT_EQ(c.axes.at(0).link, "only");
  EXPECT_EQ(c.links.at(0).port, 502);
}

TEST(MotionConfig, RejectsUnknownKeysEverywhere) {
  auto j = base();
  j["colour"] = "red";
  EXPECT_EQ(error_of(j).field(), "colour");
  j = base();
  j["links"]["bus"]["parity"] = "E";
  EXPECT_EQ(error_of(j).field(), "links.bus.parity");
  j = base();
  j["axes"]["receive"]["speed"] = 3;
  EXPECT_EQ(error_of(j).field(), "axes.receive.speed");
  j = base();
  j["reconnect"]["jitter"] = true;
  EXPECT_EQ(error_of(j).field(), "reconnect.jitter");
  j = base();
  j["axes"]["tilt"]["register_map"]["registers"] = {{"postion", 1}};
  EXPECT_EQ(error_of(j).field(), "axes.tilt.register_map.registers.postion");
  j = base();
  j["axes"]["azimuth"] = j["axes"]["tilt"];
  EXPECT_EQ(error_of(j).field(), "axes.azimuth");
}

TEST(MotionConfig, ChecksRangesAndNamesThem) {
  struct Case {
    const char* pointer;
    json value;
    const char* field;
  };
  const Case cases[] = {
      {"/axes/receive/unit", 0, "axes.receive.unit"},
      {"/axes/receive/unit", 248, "axes.receive.unit"},
      {"/axes/receive/steps_per_degree", 0, "axes.receive.steps_per_degree"},
      {"/axes/receive/speed_deg_s", 0, "axes.receive.speed_deg_s"},
      {"/axes/receive/current_percent", 101, "axes.receive.current_percent"},
      {"/axes/receive/link", "nowhere", "axes.receive.link"},
      {"/axes/receive/unit", "2", "axes.receive.unit"},
      {"/links/bus/baud", 300, "links.bus.baud"},
      {"/links/bus/format", "8X1", "links.bus.format"},
      {"/links/bus/type", "ascii", "links.bus.type"},
      {"/links/net/port", 0, "links.net.port"},
      {"/response_timeout_ms", 0, "response_timeout_ms"},
      {"/retries", 11, "retries"},
      {"/reconnect/max_ms", 10, "reconnect.max_ms"},
  };
  for (const auto& c : cases) {
    auto j = base();
    j[json::json_pointer(c.pointer)] = c.value;
    const Error e = error_of(j);
    EXPECT_NE(e.code(), Errc::internal) << c.pointer;
    EXPECT_EQ(e.field(), c.field) << c.pointer << ": " << e.what();
  }
}

TEST(MotionConfig, OldLimitKeysSayWhereSoftLimitsLiveNow) {
  struct Case {
    const char* pointer;
    json value;
    const char* field;
    const char* instead;
  };
  const Case cases[] = {
      {"/axes/receive/min_deg", -85, "axes.receive.min_deg", "receive = [MIN, MAX]"},
      {"/axes/incidence/max_deg", 80, "axes.incidence.max_deg", "incidence = [MIN, MAX]"},
      {"/min_separation_deg", 8, "min_separation_deg", "(min_separation)"},
  };
  for (const auto& c : cases) {
    auto j = base();
    j[json::json_pointer(c.pointer)] = c.value;
    const Error e = error_of(j);
    EXPECT_EQ(e.code(), Errc::invalid_argument) << c.pointer;
    EXPECT_EQ(e.field(), c.field) << c.pointer;
    const std::string what = e.what();
    EXPECT_NE(what.find(c.field), std::string::npos) << what;
    EXPECT_NE(what.find("soft limits now live in [instrument.limits]"), std::string::npos) << what;
    EXPECT_NE(what.find(c.instead), std::string::npos) << what;
  }
}

TEST(MotionConfig, RejectsStructuralMistakes) {
  auto j = base();
  j["axes"]["tilt"]["link"] = "bus";
  j["axes"]["tilt"]["unit"] = 2;  // receive already is unit 2 on bus
  EXPECT_EQ(error_of(j).field(), "axes.tilt.unit");
  j = base();
  j.erase("links");
  EXPECT_EQ(error_of(j).field(), "links");
  j = base();
  j["axes"] = json::object();
  EXPECT_EQ(error_of(j).field(), "axes");
  j = base();
  j["axes"]["receive"].erase("link");  // two links: the name is needed
  EXPECT_EQ(error_of(j).field(), "axes.receive.link");
  EXPECT_EQ(error_of(json::array()).code(), Errc::invalid_argument);
}

TEST(MotionConfig, SerialFormats) {
  mb::LinkConfig l;
  mb::parse_serial_format("f", "7o2", l);
  EXPECT_EQ(l.data_bits, 7);
  EXPECT_EQ(l.parity, 'O');
  EXPECT_EQ(l.stop_bits, 2);
  for (const char* bad : {"", "8E", "9E1", "8E3", "8Y1", "8E1x"}) {
    mb::LinkConfig x;
    EXPECT_THROW(mb::parse_serial_format("f", bad, x), Error) << bad;
  }
}
