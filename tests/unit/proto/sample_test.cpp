// A sample's specification (proto/include/gonio/proto/sample.hpp).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/sample.hpp"
#include "gonio/test/error_of.hpp"

namespace gonio {
namespace {

using nlohmann::json;

TEST(Sample, ValidatesNameToleranceAndRejectsUnknownKeys) {
  const auto s = json{{"name", "glossy-1"}, {"bsdf", "lambert:albedo=0.5"}, {"tolerance", 0.05}}.get<SampleSpec>();
  EXPECT_EQ(s.bsdf.value(), "lambert:albedo=0.5");
  const auto none = json{{"name", "x"}, {"bsdf", nullptr}}.get<SampleSpec>();
  EXPECT_FALSE(none.bsdf.has_value());
  EXPECT_EQ(test::error_of([] { (void)json{{"name", "has space"}}.get<SampleSpec>(); }).field(), "name");
  EXPECT_EQ(test::error_of([] { (void)json{{"name", "a"}, {"tolerance", 2}}.get<SampleSpec>(); }).field(), "tolerance");
  EXPECT_EQ(test::error_of([] { (void)json{{"name", "a"}, {"bdsf", "x"}}.get<SampleSpec>(); }).field(), "bdsf");
}

}  // namespace
}  // namespace gonio
