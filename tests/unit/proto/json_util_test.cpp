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
