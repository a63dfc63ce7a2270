// An alert and its resolution (proto/include/gonio/proto/alert.hpp).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/alert.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/test/error_of.hpp"

namespace gonio {
namespace {

using nlohmann::json;

TEST(Alert, RoundTripsAndParsesSeverity) {
  Alert a;
  a.id = 4;
  a.kind = std::string(alert_kind::sustained);
  a.severity = Severity::critical;
  a.dedup_key = "sustained:scan:2";
  a.scan_id = 2;
  a.message = "m";
  a.first_at = a.last_at = "2024-01-01T00:00:00.000Z";
  a.count = 3;
  EXPECT_EQ(json(a).get<Alert>(), a);
  // Standing: both resolution fields null; resolved: both set, and they round-trip.
  EXPECT_TRUE(json(a)["resolved_at"].is_null());
  EXPECT_TRUE(json(a)["resolution"].is_null());
  a.resolved_at = "2024-01-01T00:05:00.000Z";
  a.resolution = "resolved: final verdict agrees: within tolerance";
  EXPECT_EQ(json(a)["resolved_at"], "2024-01-01T00:05:00.000Z");
  EXPECT_EQ(json(a).get<Alert>(), a);
  // An alert from a peer that predates resolution still reads, as standing.
  auto old = json(a);
  old.erase("resolved_at");
  old.erase("resolution");
  EXPECT_FALSE(old.get<Alert>().resolved_at.has_value());
  EXPECT_EQ(parse_enum<Severity>("warning", "severity"), Severity::warning);
  EXPECT_EQ(test::error_of([] { (void)parse_enum<Severity>("loud", "severity"); }).field(), "severity");
}

}  // namespace
}  // namespace gonio
