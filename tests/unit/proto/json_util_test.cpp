#include "gonio/proto/json_util.hpp"

#include <gtest/gtest.h>

#include "gonio/proto/geometry.hpp"

namespace gonio::json_util {
namespace {

TEST(ObjectReader, TypedFieldsAndUnknownKeys) {
  const auto j = nlohmann::json::parse(R"({"name":"tile","tolerance":0.02,"repeats":3})");
  ObjectReader r(j, "sample");
  EXPECT_EQ(r.required<std::string>("name"), "tile");
  EXPECT_DOUBLE_EQ(r.optional<double>("tolerance", 0.0), 0.02);
  EXPECT_EQ(r.optional<int>("repeats", 1), 3);
  EXPECT_TRUE(r.optional<bool>("flag", true));
  EXPECT_NO_THROW(r.finish());

  ObjectReader r2(j, "sample");
  (void)r2.required<std::string>("name");
  try {
    r2.finish();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "sample.repeats");  // first unknown in key order
  }
  ObjectReader r3(j, "sample");
  try {
    (void)r3.required<int>("name");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "sample.name");
    EXPECT_NE(std::string(e.what()).find("expected an integer"), std::string::npos);
  }
  EXPECT_THROW(ObjectReader(nlohmann::json::array(), "p"), Error);
}

TEST(ObjectReader, BoundedNumbersNameFieldValueAndRange) {
  const auto j = nlohmann::json::parse(R"({"rate":2.5,"repeats":0,"port":80,"nan":null})");
  ObjectReader r(j, "cfg");
  EXPECT_DOUBLE_EQ(r.optional_in<double>("rate", 1.0, 0.0, 2.5), 2.5);     // bounds inclusive
  EXPECT_DOUBLE_EQ(r.optional_in<double>("absent", 1.0, 0.0, 2.0), 1.0);  // default, in range
  EXPECT_EQ(r.required_in<long long>("port", 1, 65535), 80);
  try {
    (void)r.optional_in<int>("repeats", 1, 1, 1000);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::out_of_range);
    EXPECT_EQ(e.field(), "cfg.repeats");
    EXPECT_STREQ(e.what(), "cfg.repeats = 0 is outside the allowed range [1, 1000]");
  }
  try {
    (void)r.required_in<double>("rate", 0.0, 1.0, " ms");
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "cfg.rate = 2.5 ms is outside the allowed range [0, 1] ms");
  }
  EXPECT_THROW((void)r.required_in<double>("missing", 0.0, 1.0), Error);
  // A default outside the range is a programming error, reported like a bad value.
  EXPECT_THROW((void)r.optional_in<double>("nan", 5.0, 0.0, 1.0), Error);
}

TEST(ObjectReader, NestedErrorsCarryTheFullPath) {
  const auto j = nlohmann::json::parse(R"({"geometry":{"theta_i":120,"theta_r":0}})");
  ObjectReader r(j, "params");
  try {
    (void)r.required<Geometry>("geometry");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "params.geometry.theta_i");
    EXPECT_EQ(e.code(), Errc::out_of_range);
    EXPECT_EQ(std::string(e.what()).rfind("params.geometry.theta_i = 120", 0), 0u)
        << e.what();
  }
}

}  // namespace
}  // namespace gonio::json_util
