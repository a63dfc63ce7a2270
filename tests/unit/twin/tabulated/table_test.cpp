// BsdfTable / TabulatedBsdf: validation, exactness on nodes, multilinear interpolation,
// azimuth wrap and mirror, spectral resampling, the frame convention, transmission, delta
// lobes and tabulate().
#include <array>
#include <random>

#include <gtest/gtest.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/tabulated.hpp"
#include "tab_testing.hpp"

namespace gonio::twin {
namespace {

using tabtest::error_of;
using tabtest::sph;

std::vector<double> random_values(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.1, 2.0);
  std::vector<double> v(n);
  for (auto& x : v) x = u(rng);
  return v;
}

// Where the polar angle p2 is 0 the azimuth p3 is undefined; a valid table is constant
// there, so random tables copy their p3 = first-node values across.
std::vector<double> consistent(std::vector<double> v, const BsdfTable::Axes& ax, std::size_t ch) {
  const std::size_t n0 = ax.p0.size(), n1 = std::max<std::size_t>(1, ax.p1.size());
  const std::size_t n2 = ax.p2.size(), n3 = ax.p3.size();
  for (std::size_t i2 = 0; i2 < n2; ++i2) {
    if (ax.p2[i2] != 0) continue;
    for (std::size_t i3 = 1; i3 < n3; ++i3)
      for (std::size_t k = 0; k < n0 * n1 * ch; ++k)
        v[((i3 * n2 + i2) * n0 * n1) * ch + k] = v[((0 * n2 + i2) * n0 * n1) * ch + k];
  }
  return v;
}

BsdfTable::Axes small_axes() { return {{0, 30, 60}, {}, {0, 20, 45, 80}, {0, 90, 180, 270}}; }

TEST(BsdfTable, RejectsBadAxesValuesAndSizes) {
  const auto ax = small_axes();
  const std::size_t n = 3 * 4 * 4;
  auto e = error_of([&] {
    BsdfTable(TableParam::spherical, {{0, 30, 30}, {}, ax.p2, ax.p3}, {}, random_values(n, 1));
  });
  EXPECT_EQ(e.code(), Errc::invalid_argument);
  EXPECT_EQ(e.field(), "table.p0[2]");

  e = error_of([&] {
    BsdfTable(TableParam::spherical, {ax.p0, {}, {0, 20, 45, 95}, ax.p3}, {}, random_values(n, 1));
  });
  EXPECT_EQ(e.code(), Errc::out_of_range);
  EXPECT_EQ(e.field(), "table.p2[3]");

  e = error_of([&] { BsdfTable(TableParam::spherical, ax, {}, random_values(n - 1, 1)); });
  EXPECT_EQ(e.field(), "table.values");

  auto v = random_values(n, 2);
  v[7] = -0.5;
  e = error_of([&] { BsdfTable(TableParam::spherical, ax, {}, v); });
  EXPECT_EQ(e.code(), Errc::out_of_range);
  EXPECT_EQ(e.field(), "table.values[7]");
  v[7] = std::nan("");
  e = error_of([&] { BsdfTable(TableParam::spherical, ax, {}, v); });
  EXPECT_EQ(e.field(), "table.values[7]");

  e = error_of([&] {
    BsdfTable(TableParam::spherical, ax, {}, random_values(n, 3), {false, true});
  });
  EXPECT_EQ(e.field(), "table.reduction");
  e = error_of([&] {
    BsdfTable(TableParam::spherical, {ax.p0, {}, ax.p2, {0, 90, 200}}, {}, random_values(36, 3),
              {true, false});
  });
  EXPECT_EQ(e.field(), "table.p3[2]");  // bilateral azimuths stop at 180
  e = error_of([&] {
    BsdfTable(TableParam::spherical, ax, {550, 500}, random_values(2 * n, 3));
  });
  EXPECT_EQ(e.field(), "table.wavelengths[1]");
  // A grid too large to allocate is refused before anything is allocated.
  std::vector<double> many(100000);
  for (std::size_t i = 0; i < many.size(); ++i) many[i] = 90.0 * static_cast<double>(i) / 1e5;
  e = error_of([&] { BsdfTable(TableParam::spherical, {many, {}, many, {0}}, {}, {}); });
  EXPECT_EQ(e.code(), Errc::out_of_range);
}

// Every node of a random table, evaluated at the directions of that node, returns the
// stored values (all channels) — for each parametrization.
TEST(BsdfTable, ExactOnNodesSpherical) {
  const auto ax = small_axes();
  const std::vector<double> nm{450, 550, 650};
  const BsdfTable t(TableParam::spherical, ax, nm,
                    consistent(random_values(3 * 4 * 4 * 3, 11), ax, 3));
  std::array<double, 3> f{};
  for (std::size_t i0 = 0; i0 < 3; ++i0)
    for (std::size_t i2 = 0; i2 < 4; ++i2)
      for (std::size_t i3 = 0; i3 < 4; ++i3) {
        // Isotropic: wi at any azimuth, wo at that azimuth + p3 (on the axis, wi's azimuth
        // is 180° by convention).
        const double phi_i = ax.p0[i0] == 0 ? 180.0 : 37.0;
        t.eval(sph(ax.p0[i0], phi_i), sph(ax.p2[i2], phi_i + ax.p3[i3]), f);
        for (std::size_t c = 0; c < 3; ++c)
          EXPECT_NEAR(f[c], t.at(i0, 0, i2, i3, c), 1e-12) << i0 << ' ' << i2 << ' ' << i3;
      }
}

TEST(BsdfTable, ExactOnNodesAnisotropicAndSpecular) {
  const BsdfTable::Axes ax{{10, 40}, {0, 120, 240}, {5, 30, 70}, {0, 60, 200, 330}};
  const BsdfTable t(TableParam::spherical, ax, {}, random_values(2 * 3 * 3 * 4, 12));
  double f = 0;
  for (std::size_t i0 = 0; i0 < 2; ++i0)
    for (std::size_t i1 = 0; i1 < 3; ++i1)
      for (std::size_t i2 = 0; i2 < 3; ++i2)
        for (std::size_t i3 = 0; i3 < 4; ++i3) {
          t.eval(sph(ax.p0[i0], ax.p1[i1]), sph(ax.p2[i2], ax.p3[i3]), {&f, 1});
          EXPECT_NEAR(f, t.at(i0, i1, i2, i3, 0), 1e-12);
        }

  // Specular: wo at radial r and azimuth a about the mirror direction of wi.
  const BsdfTable::Axes sx{{0, 25, 50}, {}, {0, 3, 10, 40, 120}, {0, 45, 90, 180}};
  const BsdfTable s(TableParam::specular, sx, {}, consistent(random_values(3 * 5 * 4, 13), sx, 1),
                    {true, false});
  for (std::size_t i0 = 0; i0 < 3; ++i0)
    for (std::size_t i2 = 0; i2 < 5; ++i2)
      for (std::size_t i3 = 0; i3 < 4; ++i3) {
        const Vec3 wi = tabtest::in_plane_wi(sx.p0[i0]);
        // Build wo from the documented frame: e1 toward the normal, e2 = s × e1.
        const Vec3 m = tabtest::mirror(wi);
        const Vec3 e1 = normalize(Vec3{0, 0, 1} - m * m.z);
        const Vec3 e1n = sx.p0[i0] == 0 ? Vec3{-1, 0, 0} : e1;
        const Vec3 e2 = cross(m, e1n);
        const double r = sx.p2[i2] * kDegToRad, a = sx.p3[i3] * kDegToRad;
        const Vec3 wo = m * std::cos(r) + (e1n * std::cos(a) + e2 * std::sin(a)) * std::sin(r);
        s.eval(wi, wo, {&f, 1});
        EXPECT_NEAR(f, s.at(i0, 0, i2, i3, 0), 1e-12) << i0 << ' ' << i2 << ' ' << i3;
      }
}

TEST(BsdfTable, ExactOnNodesHalfDifference) {
  const BsdfTable::Axes hx{{0, 10, 35, 60}, {}, {0, 20, 50, 80}, {0, 45, 90, 135}};
  const BsdfTable t(TableParam::half_difference, hx, {},
                    consistent(random_values(4 * 4 * 4, 14), hx, 1), {false, true});
  double f = 0;
  for (std::size_t i0 = 0; i0 < 4; ++i0)
    for (std::size_t i2 = 0; i2 < 4; ++i2)
      for (std::size_t i3 = 0; i3 < 4; ++i3) {
        Vec3 wi, wo;
        // φh is free for an isotropic table, except that at θh = 0 (h on the axis) φd is
        // measured from azimuth 0.
        const double ph = hx.p0[i0] == 0 ? 0.0 : 77.0;
        tabtest::from_half_difference(hx.p0[i0], ph, hx.p2[i2], hx.p3[i3], wi, wo);
        t.eval(wi, wo, {&f, 1});
        EXPECT_NEAR(f, t.at(i0, 0, i2, i3, 0), 1e-11) << i0 << ' ' << i2 << ' ' << i3;
        // Reciprocity reduction: φd + 180° is the same sample.
        tabtest::from_half_difference(hx.p0[i0], ph, hx.p2[i2], hx.p3[i3] + 180, wi, wo);
        t.eval(wi, wo, {&f, 1});
        EXPECT_NEAR(f, t.at(i0, 0, i2, i3, 0), 1e-11);
      }
}

// Between nodes the value is the 16-corner multilinear blend, computed here by hand.
TEST(BsdfTable, MultilinearBetweenNodes) {
  const BsdfTable::Axes ax{{0, 30, 60}, {0, 90, 180, 270}, {0, 20, 45, 80}, {0, 90, 180, 270}};
  const BsdfTable t(TableParam::spherical, ax, {}, random_values(3 * 4 * 4 * 4, 15));
  const std::array<double, 4> p{41, 100, 33, 300};
  // Lower nodes and fractions per axis.
  const std::array<std::size_t, 4> lo{1, 1, 1, 3};
  const std::array<std::size_t, 4> hi{2, 2, 2, 0};  // φo 300 lies between 270 and 360 ≡ 0
  const std::array<double, 4> frac{11.0 / 30, 10.0 / 90, 13.0 / 25, 30.0 / 90};
  double expect = 0;
  for (int corner = 0; corner < 16; ++corner) {
    double w = 1;
    std::array<std::size_t, 4> i{};
    for (int k = 0; k < 4; ++k) {
      const bool h = (corner >> k) & 1;
      w *= h ? frac[static_cast<std::size_t>(k)] : 1 - frac[static_cast<std::size_t>(k)];
      i[static_cast<std::size_t>(k)] = h ? hi[static_cast<std::size_t>(k)] : lo[static_cast<std::size_t>(k)];
    }
    expect += w * t.at(i[0], i[1], i[2], i[3], 0);
  }
  double f = 0;
  t.interpolate(p, {&f, 1});
  EXPECT_NEAR(f, expect, 1e-12);
  // The same through directions.
  t.eval(sph(41, 100), sph(33, 300), {&f, 1});
  EXPECT_NEAR(f, expect, 1e-11);
}

TEST(BsdfTable, AzimuthWrapsOrMirrorsAndPolarClamps) {
  // Values depend on φo only: 1, 2, 3, 4 at 0, 90, 180, 270.
  std::vector<double> v;
  for (double a : {1.0, 2.0, 3.0, 4.0}) v.push_back(a);
  const BsdfTable periodic(TableParam::spherical, {{30}, {}, {40}, {0, 90, 180, 270}}, {}, v);
  double f = 0;
  periodic.interpolate({30, 0, 40, 315}, {&f, 1});
  EXPECT_NEAR(f, 2.5, 1e-12);  // halfway from 4 (270) back to 1 (360)
  periodic.interpolate({30, 0, 40, -45}, {&f, 1});
  EXPECT_NEAR(f, 2.5, 1e-12);
  periodic.interpolate({30, 0, 40, 45}, {&f, 1});
  EXPECT_NEAR(f, 1.5, 1e-12);

  const BsdfTable mirrored(TableParam::spherical, {{30}, {}, {40}, {0, 60, 120, 180}}, {}, v,
                           {true, false});
  double g = 0;
  mirrored.interpolate({30, 0, 40, 300}, {&f, 1});
  mirrored.interpolate({30, 0, 40, 60}, {&g, 1});
  EXPECT_NEAR(f, g, 1e-12);
  EXPECT_NEAR(f, 2.0, 1e-12);

  // Polar axes clamp: beyond the last θo node the last value holds.
  const BsdfTable polar(TableParam::spherical, {{30}, {}, {10, 50}, {0}}, {}, {1.0, 3.0});
  polar.interpolate({30, 0, 80, 0}, {&f, 1});
  EXPECT_NEAR(f, 3.0, 1e-12);
  polar.interpolate({30, 0, 0, 0}, {&f, 1});
  EXPECT_NEAR(f, 1.0, 1e-12);
  polar.interpolate({30, 0, 20, 0}, {&f, 1});
  EXPECT_NEAR(f, 1.5, 1e-12);
}

TEST(TabulatedBsdf, ResamplesTheTableSpectrumOntoTheGrid) {
  TabulatedParts parts;
  parts.brdf = BsdfTable(TableParam::spherical, {{0}, {}, {0}, {0}}, {400, 700}, {1.0, 2.0});
  const TabulatedBsdf b(WavelengthGrid::parse("380,400:700:100,720"), parts);
  std::vector<double> f(b.channels());
  b.eval(sph(10, 0), sph(20, 90), f);
  const std::vector<double> expect{1, 1, 4.0 / 3, 5.0 / 3, 2, 2};
  for (std::size_t c = 0; c < f.size(); ++c) EXPECT_NEAR(f[c], expect[c], 1e-12) << c;

  TabulatedParts grey;
  grey.brdf = BsdfTable(TableParam::spherical, {{0}, {}, {0}, {0}}, {}, {0.25});
  const TabulatedBsdf g(WavelengthGrid::visible(), grey);
  f.assign(g.channels(), 0);
  g.eval(sph(10, 0), sph(20, 90), f);
  for (const double x : f) EXPECT_DOUBLE_EQ(x, 0.25);
  // The parts are kept as given.
  EXPECT_EQ(*g.parts().brdf, *grey.brdf);
}

// tabulate() on the docs/architecture.md §2 frame: the in-plane geometry (θi, θr) of the instrument maps
// onto the table so that the tabulated model and the model agree at every node, including
// the specular (θr = θi) and retro (θr = −θi) sides.
TEST(TabulatedBsdf, TabulateAgreesWithTheModelAtNodesInTheInstrumentFrame) {
  const auto grid = WavelengthGrid::parse("400:700:100");
  const tabtest::Lobes model(grid, 0.2, 0.5, 40);
  AngularGrid ag;
  ag.theta_i = {0, 15, 30, 45, 60};
  for (int t = 0; t <= 90; t += 5) ag.theta_o.push_back(t);
  for (int p = 0; p <= 180; p += 10) ag.phi_o.push_back(p);
  ag.bilateral = true;
  const auto table = tabulate(model, ag);
  EXPECT_EQ(table.wavelengths(), grid.values());
  const TabulatedBsdf tab(grid, TabulatedParts{table, {}, {}, {}, ""});
  std::vector<double> f(4), g(4);
  for (const double ti : ag.theta_i)
    for (const double tr : {-60.0, -30.0, -15.0, 0.0, 15.0, 30.0, 45.0, 60.0, 85.0}) {
      const Vec3 wi = tabtest::in_plane_wi(ti), wr = tabtest::in_plane_wr(tr);
      tab.eval(wi, wr, f);
      model.eval(wi, wr, g);
      for (std::size_t c = 0; c < 4; ++c)
        EXPECT_NEAR(f[c], g[c], 1e-9 * std::max(1.0, g[c])) << ti << ' ' << tr << ' ' << c;
    }
  // Out of plane too (φ on the nodes), and the peak is on the forward side.
  tab.eval(tabtest::in_plane_wi(30), sph(30, 0), f);  // forward: mirror of wi
  model.eval(tabtest::in_plane_wi(30), sph(30, 0), g);
  EXPECT_NEAR(f[0], g[0], 1e-9 * g[0]);
  tab.eval(tabtest::in_plane_wi(30), sph(30, 180), f);  // backward
  EXPECT_LT(f[0], 0.2 * g[0]);
}

TEST(TabulatedBsdf, TransmissionAndTheTwoSidedMirror) {
  const auto grid = WavelengthGrid::parse("500,600");
  const tabtest::Lobes model(grid, 0.1, 0.0, 1, 0.6, 20);
  AngularGrid ag{{0, 20, 40, 60}, {}, {0, 10, 20, 30, 40, 50, 60, 70, 80, 90}, {}, true};
  for (int p = 0; p <= 180; p += 15) ag.phi_o.push_back(p);
  const auto parts = tabulate_parts(model, ag, true, true);
  ASSERT_TRUE(parts.brdf && parts.btdf);
  EXPECT_FALSE(parts.specular_reflectance);
  const TabulatedBsdf tab(grid, parts);
  std::vector<double> f(2), g(2);
  // Straight-through direction of wi (θi = 40 in the plane): wo = −wi, below the sample.
  const Vec3 wi = tabtest::in_plane_wi(40);
  tab.eval(wi, -wi, f);
  model.eval(wi, -wi, g);
  EXPECT_NEAR(f[0], g[0], 1e-9 * g[0]);
  EXPECT_GT(f[0], 1.0);
  // Off the straight-through direction, on nodes.
  const Vec3 wo = tabtest::flip(sph(20, 90));
  tab.eval(wi, wo, f);
  model.eval(wi, wo, g);
  EXPECT_NEAR(f[1], g[1], 1e-9 * std::max(1.0, g[1]));
  // Light from below: evaluated in the mirror image.
  tab.eval(tabtest::flip(wi), tabtest::flip(-wi), g);
  tab.eval(wi, -wi, f);
  EXPECT_DOUBLE_EQ(f[0], g[0]);
  tab.eval(tabtest::flip(wi), tabtest::flip(tabtest::in_plane_wr(40)), g);
  tab.eval(wi, tabtest::in_plane_wr(40), f);
  EXPECT_DOUBLE_EQ(f[0], g[0]);
}

TEST(TabulatedBsdf, DeltaLobesFromSpecularTables) {
  const auto grid = WavelengthGrid::parse("450,650");
  const tabtest::Specular model(grid, 0.9, 0.05);
  const AngularGrid ag{{0, 30, 60, 85}, {}, {0}, {0}, false};
  const auto parts = tabulate_parts(model, ag, false, false);
  ASSERT_TRUE(parts.specular_reflectance && parts.specular_transmittance);
  EXPECT_FALSE(parts.brdf);
  const TabulatedBsdf tab(grid, parts);
  EXPECT_TRUE(tab.has_delta());
  std::vector<DeltaLobe> lobes;
  const Vec3 wo = tabtest::in_plane_wr(30);
  tab.delta_lobes(wo, lobes);
  ASSERT_EQ(lobes.size(), 2u);
  EXPECT_NEAR(lobes[0].wi.x, -wo.x, 1e-12);
  EXPECT_NEAR(lobes[0].wi.z, wo.z, 1e-12);
  EXPECT_NEAR(lobes[0].weight[1], 0.9, 1e-12);
  EXPECT_NEAR(lobes[1].wi.z, -wo.z, 1e-12);
  EXPECT_NEAR(lobes[1].weight[0], 0.05, 1e-12);
  // No diffuse table: nothing to evaluate or sample.
  std::vector<double> f(2, 1.0);
  tab.eval(tabtest::in_plane_wi(30), wo, f);
  EXPECT_EQ(f[0], 0.0);
  EXPECT_FALSE(tab.sample_wi(wo, 0.5, {0.5, 0.5}));
}

TEST(TabulatedBsdf, TabulateNamesTheGridField) {
  const tabtest::Lambert model(WavelengthGrid::parse("550"), 0.5);
  auto e = error_of([&] { tabulate(model, AngularGrid{{0, 30}, {}, {0, 40, 20}, {0, 180}, false}); });
  EXPECT_EQ(e.field(), "grid.theta_o[2]");
  EXPECT_NE(std::string(e.what()).find("grid.theta_o[2]"), std::string::npos) << e.what();
  e = error_of([&] { tabulate(model, AngularGrid{{0, 30}, {}, {0, 40}, {0, 270}, true}); });
  EXPECT_EQ(e.field(), "grid.phi_o[1]");
  e = error_of([&] { tabulate(model, AngularGrid{{0, 30}, {}, {}, {0}, false}); });
  EXPECT_EQ(e.field(), "grid.theta_o");
}

TEST(TabulatedBsdf, FromPlainArrays) {
  const auto grid = WavelengthGrid::parse("550");
  const AngularGrid ag{{0, 45}, {}, {0, 45, 90}, {0, 180}, true};
  std::vector<double> brdf(2 * 3 * 2, 0.3);
  const TabulatedBsdf t(grid, ag, {}, brdf, {}, "virtual");
  double f = 0;
  t.eval(sph(20, 0), sph(50, 33), {&f, 1});
  EXPECT_DOUBLE_EQ(f, 0.3);
  EXPECT_EQ(t.spec(), "virtual");
  EXPECT_EQ(t.parts().brdf->axis(2), ag.theta_o);
  const auto e = error_of([&] { TabulatedBsdf(grid, ag, {}, {}, {}); });
  EXPECT_EQ(e.code(), Errc::invalid_argument);
  const auto e2 = error_of([&] { TabulatedBsdf(grid, ag, {}, std::vector<double>(5, 0.1)); });
  EXPECT_EQ(e2.field(), "table.values");
}

}  // namespace
}  // namespace gonio::twin

namespace gonio::twin {
namespace {

// covers(): inside the polar axes' measured extent (no clamping to the last node), and no
// all-zero node among those the interpolation uses.
TEST(BsdfTable, CoversOnlyItsMeasuredExtentAndNonZeroNodes) {
  const auto ax = small_axes();  // θi 0–60°, θo 0–80°, φ 0–270° (periodic)
  const std::size_t n = 3 * 4 * 4;
  auto v = consistent(random_values(n, 21), ax, 1);
  const BsdfTable full(TableParam::spherical, ax, {}, v);
  EXPECT_TRUE(full.covers({30, 0, 45, 90}));
  EXPECT_TRUE(full.covers({60, 0, 80, 300}));    // on the last nodes; azimuth wraps
  EXPECT_TRUE(full.covers({12.5, 0, 33, 135}));
  EXPECT_FALSE(full.covers({61, 0, 45, 90}));    // beyond the last incidence
  EXPECT_FALSE(full.covers({30, 0, 81, 90}));    // beyond the last polar angle
  // A node marked unmeasured (0): the cells around it are not covered, the others are.
  const std::size_t i0 = 1, i2 = 3, i3 = 2;    // θi 30°, θo 80°, φ 180°
  v[full.index(i0, 0, i2, i3)] = 0;
  const BsdfTable holed(TableParam::spherical, ax, {}, v);
  EXPECT_FALSE(holed.covers({30, 0, 80, 180}));
  EXPECT_FALSE(holed.covers({40, 0, 60, 200}));  // interpolates from it
  EXPECT_TRUE(holed.covers({30, 0, 80, 90}));
  EXPECT_TRUE(holed.covers({50, 0, 30, 180}));   // its θo cell is 20–45°: the node is not used
}

}  // namespace
}  // namespace gonio::twin
