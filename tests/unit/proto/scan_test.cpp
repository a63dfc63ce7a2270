// The scan plan and its JSON form, and UTC timestamps (proto/include/gonio/proto/scan.hpp).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/scan.hpp"
#include "gonio/test/error_of.hpp"

namespace gonio {
namespace {

using nlohmann::json;

TEST(ScanPlan, ExpandsGeometriesGridsAndAstmInOrder) {
  const auto p = json{{"sample", "paint"},
                      {"geometries", {"45as15", "30/-10", {{"theta_i", 20}, {"theta_r", 5}}, "astm"}},
                      {"grids", "in=45;out=-80:80:2"},
                      {"wavelengths", "400:700:10"},
                      {"repeats", 2}}
                     .get<ScanPlan>();
  ASSERT_EQ(p.geometries.size(), 3u + 6u + 81u);
  EXPECT_EQ(p.sample_name, "paint");
  EXPECT_EQ(p.sample_id, 0);
  EXPECT_EQ(p.geometries[0], Geometry::in_plane(45, 30));
  EXPECT_EQ(p.geometries[1], Geometry::in_plane(30, -10));
  EXPECT_EQ(p.geometries[2], Geometry::in_plane(20, 5));
  EXPECT_EQ(p.geometries[3], Geometry::from_aspecular(45, -15));  // first of the ASTM set
  EXPECT_EQ(p.geometries[9], Geometry::in_plane(45, -80));
  EXPECT_EQ(p.geometries.back(), Geometry::in_plane(45, 80));
  EXPECT_EQ(p.point_count(), 2 * p.geometries.size());
  EXPECT_EQ(p.geometry_index(0), 0u);
  EXPECT_EQ(p.geometry_index(1), 0u);  // repeats of one geometry are consecutive
  EXPECT_EQ(p.geometry_index(2), 1u);
  EXPECT_EQ(p.wavelengths.size(), 31u);
}

TEST(ScanPlan, RoundTripsThroughJson) {
  auto p = json{{"sample", 7},
                {"grids", {"in=15,45;out=0:60:30"}},
                {"reference", {{"mode", "interval"}, {"interval", 4}}},
                {"priority", 5},
                {"not_before", "2030-01-02T03:04:05Z"}}
               .get<ScanPlan>();
  const auto back = json(p).get<ScanPlan>();
  EXPECT_EQ(back, p);
  EXPECT_EQ(back.reference, ReferenceMode::interval);
  EXPECT_TRUE(back.reads_reference(0));
  EXPECT_FALSE(back.reads_reference(3));
  EXPECT_TRUE(back.reads_reference(4));
}

TEST(ScanPlan, ErrorsNameTheOffendingField) {
  const auto bad = [](json j) { return test::error_of([&] { (void)j.get<ScanPlan>(); }).field(); };
  EXPECT_EQ(bad({{"geometries", {"45as15"}}}), "sample");
  EXPECT_EQ(bad({{"sample", 1}}), "geometries");
  EXPECT_EQ(bad({{"sample", 1}, {"geometries", {"45as15", {{"theta_i", 95}, {"theta_r", 0}}}}}),
            "geometries[1].theta_i");
  EXPECT_EQ(bad({{"sample", 1}, {"geometries", {"45as15"}}, {"repeats", 0}}), "repeats");
  EXPECT_EQ(bad({{"sample", 1}, {"geometries", {"45as15"}}, {"priority", 101}}), "priority");
  EXPECT_EQ(bad({{"sample", 1}, {"geometries", {"45as15"}}, {"wavelengths", "100:700:10"}}),
            "wavelengths[0]");
  EXPECT_EQ(bad({{"sample", 1}, {"geometries", {"45as15"}}, {"colour", 1}}), "colour");
  EXPECT_EQ(bad({{"sample", 1}, {"geometries", {"45as15"}}, {"not_before", "tomorrow"}}), "not_before");
  EXPECT_EQ(bad({{"sample", 1}, {"geometries", {"45as15"}}, {"reference", "sometimes"}}), "reference");
  EXPECT_EQ(bad({{"sample", 1}, {"grids", {"in=45;up=3"}}}), "grids[0].grid");
  EXPECT_EQ(bad({{"sample", 1}, {"geometries", {"45as15"}}, {"repeats", 100}, {"grids", "in=0:80:1;out=-80:80:1"}}),
            "geometries");  // 81 × 162 + 1 geometries × 100 repeats > the point limit
}

TEST(Utc, FormatsAndParsesRfc3339) {
  const auto t = utc::parse("2024-02-29T23:59:58.250Z");
  EXPECT_EQ(utc::format(t), "2024-02-29T23:59:58.250Z");
  EXPECT_EQ(utc::parse("2024-02-29T23:59:58+00:00"), utc::parse("2024-02-29T23:59:58Z"));
  EXPECT_EQ(test::error_of([] { utc::parse("2023-02-29T00:00:00Z", "when"); }).field(), "when");  // no such day
  EXPECT_EQ(test::error_of([] { utc::parse("2024-01-01T00:00:00+01:00", "when"); }).field(), "when");
  EXPECT_EQ(test::error_of([] { utc::parse("2024-01-01 00:00:00Z", "when"); }).field(), "when");
  // Lexicographic order of the format is time order (the store relies on it).
  EXPECT_LT(utc::format(utc::parse("2024-01-01T09:00:00Z")), utc::format(utc::parse("2024-01-01T10:00:00Z")));
}

}  // namespace
}  // namespace gonio
