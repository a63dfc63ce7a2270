#include "gonio/proto/json_writer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include <nlohmann/json.hpp>

namespace gonio {
namespace {

using nlohmann::json;

TEST(JsonWriter, WritesWhatNlohmannReadsBack) {
  std::string out;
  JsonWriter w(out);
  w.begin_object()
      .member("name", "goniod")
      .member("count", std::size_t{3})
      .member("delta", -7)
      .member("share", 0.05)
      .member("whole", 2.0)
      .member("on", true)
      .member("none", nullptr)
      .member("maybe", std::optional<std::int64_t>{})
      .member("some", std::optional<std::int64_t>{42})
      .begin_array("list")
      .element(1)
      .element("two")
      .begin_object()
      .member("k", 3.5)
      .end_object()
      .end_array()
      .begin_object("empty")
      .end_object()
      .raw_member("raw", R"({"a":[1,2]})")
      .end_object();
  const auto j = json::parse(out);
  EXPECT_EQ(j, json::parse(R"({"name":"goniod","count":3,"delta":-7,"share":0.05,"whole":2.0,
      "on":true,"none":null,"maybe":null,"some":42,"list":[1,"two",{"k":3.5}],"empty":{},
      "raw":{"a":[1,2]}})"));
  // A double stays a double for typed readers, an integer an integer.
  EXPECT_TRUE(j["whole"].is_number_float());
  EXPECT_TRUE(j["count"].is_number_unsigned());
  EXPECT_TRUE(j["delta"].is_number_integer());
}

TEST(JsonWriter, ContinuesAnOpenObject) {
  // system.info writes its fixed members once and its live members after them.
  std::string out = R"({"name":"goniod")";
  JsonWriter(out).member("uptime_s", 1.5).end_object();
  EXPECT_EQ(json::parse(out), json::parse(R"({"name":"goniod","uptime_s":1.5})"));
  std::string open = "{";
  JsonWriter(open).member("a", 1).member("b", 2).end_object();
  EXPECT_EQ(open, R"({"a":1,"b":2})");
}

TEST(JsonWriter, DoublesReadBackExactly) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> exponent(-300.0, 300.0);
  for (int i = 0; i < 2000; ++i) {
    const double v = (i % 2 ? -1.0 : 1.0) * std::pow(10.0, exponent(rng)) * (1.0 + 1e-3 * i);
    std::string out;
    JsonWriter(out).begin_object().member("v", v).end_object();
    const auto j = json::parse(out);
    ASSERT_TRUE(j["v"].is_number_float()) << out;
    EXPECT_EQ(j["v"].get<double>(), v) << out;
  }
  for (const double v : {0.0, -0.0, 1.0, 1e21, 123456789.0, 5e-324}) {
    std::string out;
    JsonWriter(out).begin_array().element(v).end_array();
    EXPECT_EQ(json::parse(out)[0].get<double>(), v) << out;
  }
}

TEST(JsonWriter, NonFiniteNumbersAreNull) {
  std::string out;
  JsonWriter(out)
      .begin_object()
      .member("nan", std::numeric_limits<double>::quiet_NaN())
      .member("inf", -std::numeric_limits<double>::infinity())
      .end_object();
  EXPECT_EQ(out, R"({"nan":null,"inf":null})");
}

TEST(JsonWriter, EscapesStringsAsTheRestOfTheApi) {
  const std::string nasty = std::string("q\"b\\s\n\t\x01 é ") + "\xff" + "end";
  std::string out;
  JsonWriter(out).begin_object().member(nasty, nasty).end_object();
  const auto j = json::parse(out);
  // Invalid UTF-8 is replaced (U+FFFD), as every answer's serialisation does.
  const auto expected = json(nasty).dump(-1, ' ', false, json::error_handler_t::replace);
  ASSERT_EQ(j.size(), 1u);
  EXPECT_EQ(json(j.begin().key()).dump(), expected);
  EXPECT_EQ(j.begin().value().dump(), expected);
  EXPECT_NE(out.find(R"(\"b\\s\n\t\u0001)"), std::string::npos) << out;
}

TEST(JsonWriter, EveryIntegerWidth) {
  std::string out;
  JsonWriter(out)
      .begin_array()
      .element(std::numeric_limits<std::int64_t>::min())
      .element(std::numeric_limits<std::uint64_t>::max())
      .element(static_cast<short>(-3))
      .element(static_cast<unsigned char>(200))
      .end_array();
  const auto j = json::parse(out);
  EXPECT_EQ(j[0].get<std::int64_t>(), std::numeric_limits<std::int64_t>::min());
  EXPECT_EQ(j[1].get<std::uint64_t>(), std::numeric_limits<std::uint64_t>::max());
  EXPECT_EQ(j[2], -3);
  EXPECT_EQ(j[3], 200);
}

}  // namespace
}  // namespace gonio
