// scan.export: CSV rows, and tables that the twin's own readers read back.
#include <array>
#include <cmath>
#include <numbers>
#include <sstream>

#include <gtest/gtest.h>

#include "gonio/daemon/store/export.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf_io.hpp"

namespace gonio::daemon {
namespace {

// A full in-plane grid θi ∈ {30, 45}, θr ∈ {−20, 0, 20}, 3 channels, β = a known function.
double beta(double ti, double tr, std::size_t c) { return 0.1 + 0.01 * ti + 0.002 * (tr + 20) + 0.05 * static_cast<double>(c); }

std::pair<Scan, std::vector<PointRecord>> grid_scan(bool with_negative = false) {
  Scan s;
  s.id = 9;
  s.plan.sample_id = 1;
  s.plan.wavelengths = WavelengthGrid::parse("450,550,650");
  std::vector<PointRecord> pts;
  for (double ti : {30.0, 45.0})
    for (double tr : {-20.0, 0.0, 20.0}) {
      PointRecord p;
      p.scan_id = 9;
      p.index = static_cast<std::int64_t>(pts.size());
      p.planned = p.actual = Geometry::in_plane(ti, tr);
      std::vector<double> v;
      for (std::size_t c = 0; c < 3; ++c) v.push_back(beta(ti, tr, c));
      if (with_negative && pts.empty()) v[0] = -0.001;
      p.measured = Spectrum(s.plan.wavelengths, v, {0.001, 0.001, 0.001});
      pts.push_back(p);
    }
  s.plan.geometries.resize(pts.size());
  return {s, pts};
}

TEST(Export, CsvHasOneRowPerPointAndChannel) {
  const auto [scan, pts] = grid_scan();
  const auto e = export_scan(scan, pts, "csv");
  EXPECT_EQ(e.filename, "scan-9.csv");
  std::istringstream in(e.content);
  std::string line;
  int rows = 0;
  while (std::getline(in, line))
    if (!line.empty() && line[0] != '#' && !line.starts_with("index")) ++rows;
  EXPECT_EQ(rows, 6 * 3);
}

TEST(Export, SsddReadsBackAsTheMeasuredBrdf) {
  const auto [scan, pts] = grid_scan();
  const auto e = export_scan(scan, pts, "ssdd");
  std::istringstream in(e.content);
  const auto parts = twin::read_ssdd(in, "export");
  ASSERT_TRUE(parts.brdf.has_value());
  const auto& t = *parts.brdf;
  EXPECT_EQ(t.axes().p0, (std::vector<double>{30, 45}));
  EXPECT_EQ(t.axes().p2, (std::vector<double>{0, 20}));
  EXPECT_EQ(t.axes().p3, (std::vector<double>{0, 180}));
  // θi = 45, θr = +20 is φo = 180 (forward), θo = 20: f = β/π.
  for (std::size_t c = 0; c < 3; ++c) {
    EXPECT_NEAR(t.at(1, 0, 1, 1, c), beta(45, 20, c) / std::numbers::pi, 1e-6);
    EXPECT_NEAR(t.at(0, 0, 1, 0, c), beta(30, -20, c) / std::numbers::pi, 1e-6);
    EXPECT_NEAR(t.at(0, 0, 0, 0, c), beta(30, 0, c) / std::numbers::pi, 1e-6);
  }
}

TEST(Export, IssaWritesAndNegativeNoiseIsClamped) {
  const auto [scan, pts] = grid_scan(true);
  const auto e = export_scan(scan, pts, "bsdf");
  std::istringstream in(e.content);
  const auto parts = twin::read_issa(in, "export");
  EXPECT_TRUE(parts.brdf.has_value());
  // A spectral scan keeps its colour: tristimulus blocks, not one grey channel.
  EXPECT_NE(e.content.find("SpectralContent\tXYZ"), std::string::npos);
  EXPECT_EQ(e.content.find("SpectralContent\tMonochrome"), std::string::npos);
}

// The walk-through's scan: θi = 45°, θr = −30…80° every 2° — the mirrored angles down to
// −80° (and the collision zone around −45°) can never be measured.
std::pair<Scan, std::vector<PointRecord>> walk_through_scan() {
  Scan s;
  s.id = 1;
  s.plan.sample_id = 1;
  s.plan.wavelengths = WavelengthGrid::parse("450,550,650");
  std::vector<PointRecord> pts;
  for (double tr = -30; tr <= 80; tr += 2) {
    PointRecord p;
    p.scan_id = 1;
    p.index = static_cast<std::int64_t>(pts.size());
    p.planned = p.actual = Geometry::in_plane(45, tr);
    std::vector<double> v;
    for (std::size_t c = 0; c < 3; ++c) v.push_back(beta(45, tr, c));
    p.measured = Spectrum(s.plan.wavelengths, v, {0.001, 0.001, 0.001});
    pts.push_back(p);
  }
  s.plan.geometries.resize(pts.size());
  return {s, pts};
}

twin::BsdfTable read_back(const ExportResult& e) {
  std::istringstream in(e.content);
  const auto parts = e.format == "bsdf" ? twin::read_issa(in, "export") : twin::read_ssdd(in, "export");
  EXPECT_TRUE(parts.brdf.has_value());
  return parts.brdf ? *parts.brdf : twin::BsdfTable{};
}

std::array<double, 4> coords_of(const twin::BsdfTable& t, double ti, double tr) {
  const auto g = Geometry::in_plane(ti, tr);
  const auto a = g.incident_direction(), b = g.receiving_direction();
  return t.coords({a[0], a[1], a[2]}, {b[0], b[1], b[2]});
}

TEST(Export, TablesOfAScanWithAGapKeepTheGapUnmeasured) {
  const auto [scan, pts] = walk_through_scan();
  for (const std::string format : {"ssdd", "bsdf"}) {
    SCOPED_TRACE(format);
    const auto e = export_scan(scan, pts, format);
    // The header says what was not measured.
    EXPECT_NE(e.content.find("# not measured (25 nodes"), std::string::npos) << e.content.substr(0, 600);
    EXPECT_NE(e.content.find("#   theta_i = 45 deg: theta_r = -80 to -32 deg"), std::string::npos);
    const auto t = read_back(e);
    ASSERT_FALSE(t.empty());
    std::vector<double> f(t.channels());
    // Every measured geometry reads back as measured, with its stored value (IS-SA keeps
    // the luminance factor Y of the three channels: compare with a grey scan's Y).
    for (double tr = -30; tr <= 80; tr += 2) {
      const auto p = coords_of(t, 45, tr);
      EXPECT_TRUE(t.covers(p)) << "θr = " << tr;
      t.interpolate(p, f);
      if (format == "ssdd") {
        for (std::size_t c = 0; c < 3; ++c)
          EXPECT_NEAR(f[c], beta(45, tr, c) / std::numbers::pi, 1e-9) << "θr = " << tr;
      } else {
        EXPECT_GT(f[0], 0) << "θr = " << tr;
      }
    }
    // The mirrored side the arms cannot reach is unmeasured, not a blend.
    for (double tr : {-32.0, -45.0, -60.0, -80.0}) {
      EXPECT_FALSE(t.covers(coords_of(t, 45, tr))) << "θr = " << tr;
    }
  }
}

TEST(Export, IssaWritesTheMeasuredValuesAsTheyAre) {
  // One channel: IS-SA Monochrome holds f itself, so values compare exactly.
  auto [scan, pts] = walk_through_scan();
  scan.plan.wavelengths = WavelengthGrid::parse("550");
  for (auto& p : pts) p.measured = Spectrum(scan.plan.wavelengths, {p.measured.values[1]}, {0.001});
  const auto t = read_back(export_scan(scan, pts, "bsdf"));
  ASSERT_FALSE(t.empty());
  std::vector<double> f(1);
  for (double tr = -30; tr <= 80; tr += 2) {
    t.interpolate(coords_of(t, 45, tr), f);
    EXPECT_NEAR(f[0], beta(45, tr, 1) / std::numbers::pi, 1e-9) << "θr = " << tr;
  }
}

TEST(Export, RejectsWhatIsNotATable) {
  auto [scan, pts] = grid_scan();
  pts.front().planned = Geometry{45, 0, 20, 90};  // out of the plane of measurement
  try {
    (void)export_scan(scan, pts, "ssdd");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::unsupported);
  }
  try {
    (void)export_scan(scan, pts, "xlsx");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "format");
  }
}

}  // namespace
}  // namespace gonio::daemon
