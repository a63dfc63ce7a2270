// Master references (twin/include/gonio/twin/master.hpp): interpolation along the aspecular
// angle, its uncertainty, what a master covers, its table, and the leave-one-out coverage of
// the interpolation's u on the shared measured table and on a glossy sample measured by the
// twin.
#include <cmath>
#include <fstream>
#include <numbers>
#include <string>

#include <gtest/gtest.h>

#include "gonio/twin/bsdf_io.hpp"
#include "gonio/twin/master.hpp"
#include "gonio/twin/twin.hpp"

namespace gonio::twin {
namespace {

const std::string kRealTable =
    std::string(GONIO_SOURCE_DIR) + "/../shared/data/real/radiant-imaging-sphere-brdf.bsdf";

// One curve at θi = 45 of β(x) = 0.2 + 0.001·x² over x = θi − θr in −20…20 every 4°.
Master quadratic(double u = 0) {
  std::vector<MasterPoint> pts;
  for (double x = -20; x <= 20; x += 4) pts.push_back({45, 45 - x, {0.2 + 0.001 * x * x}, {u}});
  return Master({550}, pts);
}

TEST(Master, ExactAtItsNodesWithTheNodesOwnU) {
  const auto m = quadratic(0.002);
  const auto e = m.at(Geometry::in_plane(45, 37));  // x = 8
  EXPECT_DOUBLE_EQ(e.beta[0], 0.2 + 0.001 * 64);
  EXPECT_DOUBLE_EQ(e.u_measured[0], 0.002);
  EXPECT_EQ(e.u_interpolation[0], 0);
}

TEST(Master, TheInterpolationUIsTheErrorBoundOfAQuadratic) {
  // β'' = 0.002 everywhere, so the bound (x − a)(b − x)/2·β'' is the error itself.
  const auto m = quadratic();
  for (double x : {1.0, 2.0, 3.0, 10.5, -17.0}) {
    const auto e = m.at(Geometry::from_aspecular(45, x));
    const double truth = 0.2 + 0.001 * x * x;
    EXPECT_NEAR(e.u_interpolation[0], std::abs(e.beta[0] - truth), 1e-12) << x;
    EXPECT_GT(e.u_interpolation[0], 0) << x;
  }
}

TEST(Master, RepeatsAreMergedIntoTheirMean) {
  std::vector<MasterPoint> pts{{30, 20, {0.1}, {0.01}}, {30, 20, {0.3}, {0.01}}, {30, 25, {0.2}, {0.01}},
                               {30, 35, {0.2}, {0.01}}};
  const Master m({550}, pts);
  ASSERT_EQ(m.points().size(), 3u);
  const auto e = m.at(Geometry::in_plane(30, 20));
  EXPECT_DOUBLE_EQ(e.beta[0], 0.2);
  EXPECT_NEAR(e.u_measured[0], 0.01 / std::sqrt(2.0), 1e-15);
}

TEST(Master, CoversItsIncidencesAndReceivingRangeOnly) {
  const auto m = quadratic();
  EXPECT_EQ(m.uncovered(Geometry::in_plane(45, 30)), "");
  EXPECT_EQ(m.uncovered(Geometry::in_plane(45.03, 30)), "");  // the same incidence, read back
  EXPECT_NE(m.uncovered(Geometry::in_plane(30, 30)).find("θi = 30°"), std::string::npos);
  EXPECT_NE(m.uncovered(Geometry::in_plane(45, 70)).find("outside the master's receiving range"), std::string::npos);
  EXPECT_NE(m.uncovered(Geometry{45, 0, 30, 10}).find("plane of measurement"), std::string::npos);
  try {
    (void)m.at(Geometry::in_plane(45, 80));
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "geometry");
  }
}

TEST(Master, BadPointsAreRefusedNamingTheField) {
  const auto field_of = [](std::vector<MasterPoint> pts) {
    try {
      Master({550}, std::move(pts), "reference.points");
    } catch (const Error& e) {
      return e.field();
    }
    return std::string("no error");
  };
  EXPECT_EQ(field_of({{45, 30, {0.1, 0.2}, {0, 0}}}), "reference.points[0].beta");
  EXPECT_EQ(field_of({{45, 30, {-0.1}, {0}}}), "reference.points[0].beta[0]");
  EXPECT_EQ(field_of({{45, 30, {0.1}, {0}}, {45, 31, {0.1}, {0}}}), "reference.points");  // 2 < 3 nodes
  EXPECT_EQ(field_of({{45, 120, {0.1}, {0}}}), "reference.points[0]");
}

TEST(Master, ItsTableGivesTheTwinTheMastersValuesInThePlane) {
  const auto m = quadratic();
  const auto t = m.table();
  EXPECT_EQ(t.param(), TableParam::specular);
  for (double x : {-20.0, -6.0, 0.0, 2.0, 13.0}) {
    const double ti = 45 * kDegToRad, tr = (45 - x) * kDegToRad;
    const Vec3 wi{-std::sin(ti), 0, std::cos(ti)}, wo{std::sin(tr), 0, std::cos(tr)};
    double f = 0;
    t.eval(wi, wo, {&f, 1});
    EXPECT_NEAR(std::numbers::pi * f, m.at(Geometry::from_aspecular(45, x)).beta[0], 1e-9) << x;
  }
}

// The in-plane nodes of a specular table (azimuth 0 and 180 about the specular direction)
// as master points, u the stated relative `rel` of each value.
Master in_plane_nodes(const BsdfTable& t, double rel) {
  std::vector<MasterPoint> pts;
  const auto& th = t.axis(0);
  const auto& radial = t.axis(2);
  const auto& az = t.axis(3);
  for (std::size_t i = 0; i < th.size(); ++i)
    for (std::size_t a = 0; a < az.size(); ++a) {
      if (az[a] != 0 && az[a] != 180) continue;
      for (std::size_t j = 0; j < radial.size(); ++j) {
        if (az[a] == 180 && radial[j] == 0) continue;  // the specular node once
        const double x = az[a] == 0 ? radial[j] : -radial[j];
        const double tr = th[i] - x;
        const double beta = std::numbers::pi * t.at(i, 0, j, a, 0);
        if (std::abs(tr) >= 85 || beta <= 0) continue;  // below the horizon, or not measured
        pts.push_back({th[i], tr, {beta}, {rel * beta}});
      }
    }
  return Master({550}, pts);
}

TEST(Master, LeaveOneOutCoverageOnTheSharedMeasuredTable) {
  ASSERT_TRUE(std::ifstream(kRealTable).good()) << kRealTable << " is missing";
  const auto parts = read_issa(kRealTable);
  ASSERT_TRUE(parts.brdf);
  // The imaging sphere's own repeatability is not stated; 1 % is what the inverse twin
  // assumes of a table (TableUncertainty).
  const auto loo = in_plane_nodes(*parts.brdf, 0.01).leave_one_out();
  std::printf("shared table, %zu left out: %.3f within 1u, %.3f within 2u, rms z %.2f\n", loo.residuals,
              loo.fraction(1), loo.fraction(2), loo.rms_z);
  EXPECT_GT(loo.residuals, 150u);
  const auto bare = in_plane_nodes(*parts.brdf, 0).leave_one_out();  // the interpolation's u alone
  std::printf("  interpolation u alone: %.3f within 1u, %.3f within 2u\n", bare.fraction(1), bare.fraction(2));
  EXPECT_GE(loo.fraction(2), 0.95);
  EXPECT_GE(loo.fraction(1), 0.68);
}

TEST(Master, LeaveOneOutCoverageOnAGlossySampleMeasuredByTheTwin) {
  // A glossy conductor through the GCMS-4's apertures, θi = 45, θr 15…75 every 1°: the peak
  // (aperture-widened) spans a few nodes, where the curvature changes fastest.
  const WavelengthGrid grid({450, 550, 650});
  const Twin tw(InstrumentProfile::preset("gcms4"), make_bsdf("conductor:alpha=0.05,eta=0.2,k=3.9", grid), grid);
  EstimatorOptions o;
  o.rel_se = 0.003;
  o.replicates = 8;
  std::vector<MasterPoint> pts;
  for (double tr = 15; tr <= 75; tr += 1) {
    const auto p = tw.predict(Geometry::in_plane(45, tr), o);
    pts.push_back({45, tr, p.beta, p.std_error});
  }
  const Master m(grid.values(), pts);
  const auto loo = m.leave_one_out();
  std::printf("glossy twin sample, %zu left out: %.3f within 1u, %.3f within 2u, rms z %.2f\n", loo.residuals,
              loo.fraction(1), loo.fraction(2), loo.rms_z);
  EXPECT_GE(loo.fraction(2), 0.95);
  EXPECT_GE(loo.fraction(1), 0.68);
}

}  // namespace
}  // namespace gonio::twin
