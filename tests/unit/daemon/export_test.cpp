// scan.export: CSV rows, and tables that the twin's own readers read back.
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

TEST(Export, RejectsWhatIsNotATable) {
  auto [scan, pts] = grid_scan();
  pts.pop_back();  // a hole in the grid
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
