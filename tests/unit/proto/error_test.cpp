#include "gonio/proto/error.hpp"

#include <gtest/gtest.h>

namespace gonio {
namespace {

TEST(Error, IdsAreStableAndRoundTrip) {
  EXPECT_EQ(errc_id(Errc::out_of_range), "out_of_range");
  EXPECT_EQ(errc_id(Errc::plan_rejected), "plan_rejected");
  EXPECT_EQ(static_cast<int>(Errc::timeout), 10);
  EXPECT_EQ(static_cast<int>(Errc::plan_rejected), 23);
  for (int c : {1, 2, 3, 4, 5, 6, 10, 11, 12, 13, 14, 15, 16, 20, 21, 22, 23, 99}) {
    const auto e = static_cast<Errc>(c);
    EXPECT_EQ(errc_from_id(errc_id(e)), e) << c;
  }
  EXPECT_EQ(errc_from_id("no_such_id"), Errc::internal);
}

TEST(Error, OutOfRangeNamesFieldValueAndRange) {
  const auto e = Error::out_of_range("geometry.theta_i", 95, 0, 89.9, "°");
  EXPECT_EQ(e.code(), Errc::out_of_range);
  EXPECT_EQ(e.field(), "geometry.theta_i");
  EXPECT_STREQ(e.what(), "geometry.theta_i = 95° is outside the allowed range [0, 89.9]°");
}

}  // namespace
}  // namespace gonio
