// Value types of the daemon's API (proto/include/gonio/proto/{scan,point,alert,sample}.hpp).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/alert.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/point.hpp"
#include "gonio/proto/sample.hpp"
#include "gonio/proto/scan.hpp"

namespace gonio {
namespace {

using nlohmann::json;

// The field an Error names, or "" when `f` does not throw one.
template <typename F>
std::string field_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.field();
  }
  return "<no error>";
}

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
  const auto bad = [](json j) { return field_of([&] { (void)j.get<ScanPlan>(); }); };
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
  EXPECT_EQ(field_of([] { utc::parse("2023-02-29T00:00:00Z", "when"); }), "when");  // no such day
  EXPECT_EQ(field_of([] { utc::parse("2024-01-01T00:00:00+01:00", "when"); }), "when");
  EXPECT_EQ(field_of([] { utc::parse("2024-01-01 00:00:00Z", "when"); }), "when");
  // Lexicographic order of the format is time order (the store relies on it).
  EXPECT_LT(utc::format(utc::parse("2024-01-01T09:00:00Z")), utc::format(utc::parse("2024-01-01T10:00:00Z")));
}

TEST(Sample, ValidatesNameToleranceAndRejectsUnknownKeys) {
  const auto s = json{{"name", "glossy-1"}, {"bsdf", "lambert:albedo=0.5"}, {"tolerance", 0.05}}.get<SampleSpec>();
  EXPECT_EQ(s.bsdf.value(), "lambert:albedo=0.5");
  const auto none = json{{"name", "x"}, {"bsdf", nullptr}}.get<SampleSpec>();
  EXPECT_FALSE(none.bsdf.has_value());
  EXPECT_EQ(field_of([] { (void)json{{"name", "has space"}}.get<SampleSpec>(); }), "name");
  EXPECT_EQ(field_of([] { (void)json{{"name", "a"}, {"tolerance", 2}}.get<SampleSpec>(); }), "tolerance");
  EXPECT_EQ(field_of([] { (void)json{{"name", "a"}, {"bdsf", "x"}}.get<SampleSpec>(); }), "bdsf");
}

TEST(PointRecord, RoundTripsWithAndWithoutPrediction) {
  PointRecord p;
  p.scan_id = 3;
  p.index = 17;
  p.geometry_index = 8;
  p.repeat = 1;
  p.planned = Geometry::in_plane(45, -30);
  p.actual = Geometry::in_plane(45.01, -29.98);
  p.started_at = "2024-01-01T00:00:00.000Z";
  p.finished_at = "2024-01-01T00:00:01.000Z";
  p.measured = Spectrum(WavelengthGrid::parse("400,500"), {0.5, 0.6}, {0.01, 0.02});
  p.flags = {"reference_read"};
  EXPECT_EQ(json(p).get<PointRecord>(), p);
  p.predicted = Spectrum(WavelengthGrid::parse("400,500"), {0.52, 0.61}, {0.003, 0.004});
  p.twin_version = "t";
  p.z_max = 1.5;
  p.delta_e00 = 0.7;
  p.diverged = true;
  EXPECT_EQ(json(p).get<PointRecord>(), p);
  auto j = json(p);
  j["extra"] = 1;
  EXPECT_EQ(field_of([&] { (void)j.get<PointRecord>(); }), "extra");
}

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
  EXPECT_EQ(field_of([] { (void)parse_enum<Severity>("loud", "severity"); }), "severity");
}

}  // namespace
}  // namespace gonio
