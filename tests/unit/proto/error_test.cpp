// gonio::Error: stable ids and numbers, and the one message format of each factory.
#include "gonio/proto/error.hpp"

#include <gtest/gtest.h>

namespace gonio {
namespace {

TEST(Error, IdsAreStableAndRoundTrip) {
  EXPECT_EQ(errc_id(Errc::out_of_range), "out_of_range");
  EXPECT_EQ(errc_id(Errc::plan_rejected), "plan_rejected");
  EXPECT_EQ(static_cast<int>(Errc::timeout), 10);
  EXPECT_EQ(static_cast<int>(Errc::plan_rejected), 23);
  EXPECT_EQ(static_cast<int>(Errc::storage_unavailable), 24);
  for (int c : {1, 2, 3, 4, 5, 6, 10, 11, 12, 13, 14, 15, 16, 20, 21, 22, 23, 24, 99}) {
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

TEST(Error, InvalidPrefixesTheField) {
  const auto e = Error::invalid("format", "'xml' is not an export format");
  EXPECT_EQ(e.code(), Errc::invalid_argument);
  EXPECT_EQ(e.field(), "format");
  EXPECT_STREQ(e.what(), "format: 'xml' is not an export format");
  EXPECT_STREQ(Error::invalid("", "no field").what(), "no field");
}

TEST(Error, NotFoundHasOneFormat) {
  const auto e = Error::not_found("scan", "scan 7");
  EXPECT_EQ(e.code(), Errc::not_found);
  EXPECT_EQ(e.field(), "scan");
  EXPECT_STREQ(e.what(), "scan: scan 7 does not exist");
  const auto n = Error::not_found("plan.sample", "sample 'tile'");
  EXPECT_EQ(n.field(), "plan.sample");
  EXPECT_STREQ(n.what(), "plan.sample: sample 'tile' does not exist");
  EXPECT_STREQ(Error::not_found("", "preset 'x'").what(), "preset 'x' does not exist");
}

TEST(Error, ExistsAndWrongStateAreInvalidState) {
  const auto e = Error::exists("name", "a sample named 'tile'");
  EXPECT_EQ(e.code(), Errc::invalid_state);
  EXPECT_EQ(e.field(), "name");
  EXPECT_STREQ(e.what(), "name: a sample named 'tile' already exists");
  const auto w = Error::wrong_state("scan", "scan 3 is completed; only paused scans can be resumed");
  EXPECT_EQ(w.code(), Errc::invalid_state);
  EXPECT_EQ(w.field(), "scan");
  EXPECT_STREQ(w.what(), "scan: scan 3 is completed; only paused scans can be resumed");
  EXPECT_STREQ(Error::wrong_state("", "goniod is stopping").what(), "goniod is stopping");
}

TEST(Error, ForbiddenNamesTheRoles) {
  const auto e = Error::forbidden("scan.submit", "technician", "kiosk", "viewer");
  EXPECT_EQ(e.code(), Errc::forbidden);
  EXPECT_EQ(e.field(), "");
  EXPECT_STREQ(e.what(), "scan.submit needs the technician role; 'kiosk' has viewer");
}

}  // namespace
}  // namespace gonio
