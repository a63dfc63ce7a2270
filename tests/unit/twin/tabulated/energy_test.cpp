// Energy and colour of written tables: a model tabulated on its lobe-following grid and
// written as IS-SA (and SSDD) reflects, as a reader interpolates the file, what the model
// reflects — within 2 % at θi = 0…85° for a Lambertian, a rough conductor and glossy ones —
// and a coloured material keeps its CIELAB through the XYZ blocks of IS-SA.
//
// The model's directional albedo is computed here by a dense quadrature of its eval, in the
// mirror frame with radial steps shrinking quadratically toward the specular direction —
// independent of the library's integrator and of the twin's estimator.
#include <cmath>
#include <sstream>

#include <gtest/gtest.h>

#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/bsdf_io.hpp"
#include "gonio/twin/color.hpp"
#include "gonio/twin/tabulated.hpp"
#include "tab_testing.hpp"

namespace gonio::twin {
namespace {

// ∫ f(wi, wo) cos θo dωo per channel, f given as a callable filling a span.
template <typename F>
std::vector<double> dense_albedo(F&& f, std::size_t channels, double theta_i) {
  const Vec3 wi = tabtest::in_plane_wi(theta_i);
  const Vec3 s = tabtest::mirror(wi);
  const double st = std::sqrt(s.x * s.x + s.y * s.y);
  const Vec3 e1 = st < 1e-12 ? Vec3{-1, 0, 0} : normalize(Vec3{0, 0, 1} - s * s.z);
  const Vec3 e2 = cross(s, e1);
  constexpr int kR = 1000, kA = 960;
  std::vector<double> sum(channels, 0.0), v(channels);
  for (int i = 0; i < kR; ++i) {
    const double u0 = double(i) / kR, u1 = double(i + 1) / kR;
    const double r0 = kPi * u0 * u0, r1 = kPi * u1 * u1, rm = 0.5 * (r0 + r1);
    const double dmu = std::cos(r0) - std::cos(r1);
    for (int j = 0; j < kA; ++j) {
      const double a = (j + 0.5) * 2 * kPi / kA;
      const Vec3 wo = s * std::cos(rm) + (e1 * std::cos(a) + e2 * std::sin(a)) * std::sin(rm);
      if (!(wo.z > 0)) continue;
      f(wi, wo, std::span<double>(v));
      for (std::size_t c = 0; c < channels; ++c) sum[c] += v[c] * wo.z * dmu * 2 * kPi / kA;
    }
  }
  return sum;
}

std::vector<double> model_dense(const Bsdf& m, double ti) {
  return dense_albedo([&](const Vec3& a, const Vec3& b, std::span<double> o) { m.eval(a, b, o); },
                      m.channels(), ti);
}
std::vector<double> table_dense(const BsdfTable& t, double ti) {
  return dense_albedo([&](const Vec3& a, const Vec3& b, std::span<double> o) { t.eval(a, b, o); },
                      t.channels(), ti);
}

// The TIS values of an IS-SA text, in file order.
std::vector<double> tis_lines(const std::string& text) {
  std::vector<double> v;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("TIS ", 0) == 0) v.push_back(std::stod(line.substr(4)));
  return v;
}

const std::vector<double> kIncidence{0, 15, 30, 45, 60, 70, 75, 80, 85};

void expect_energy_kept(const std::string& spec) {
  SCOPED_TRACE(spec);
  const auto model = make_bsdf(spec, WavelengthGrid::parse("550"));
  const SpecularGrid grid = lobe_grid(*model);
  const BsdfTable table = tabulate_specular(*model, grid);
  std::ostringstream issa;
  const auto warnings = write_issa(issa, table, false);
  EXPECT_TRUE(warnings.empty()) << warnings.front();
  std::istringstream in(issa.str());
  const BsdfTable back = *read_issa(in).brdf;
  const auto tis = tis_lines(issa.str());
  ASSERT_EQ(tis.size(), grid.theta_i.size());
  for (const double ti : kIncidence) {
    SCOPED_TRACE(ti);
    const double m = model_dense(*model, ti)[0];
    const double t = table_dense(back, ti)[0];
    EXPECT_NEAR(t / m, 1.0, 0.02) << "table " << t << ", model " << m;
    EXPECT_LE(t, 1.0);
    const auto it = std::find(grid.theta_i.begin(), grid.theta_i.end(), ti);
    ASSERT_NE(it, grid.theta_i.end());
    EXPECT_NEAR(tis[static_cast<std::size_t>(it - grid.theta_i.begin())] / m, 1.0, 0.02);
  }
}

// The glossy lobes need fine grids and dense reference integrals: seconds each in an
// optimised build (the ci preset), minutes under the sanitizers' unoptimised build, which
// runs the Lambertian and the coarse-grid cases through the same code.
#ifdef NDEBUG
#define SKIP_UNLESS_OPTIMISED() (void)0
#else
#define SKIP_UNLESS_OPTIMISED() GTEST_SKIP() << "dense quadrature: run in an optimised build"
#endif

TEST(TableEnergy, LambertianKeepsItsAlbedo) { expect_energy_kept("lambert:albedo=0.8"); }
TEST(TableEnergy, RoughConductorKeepsItsAlbedo) {
  SKIP_UNLESS_OPTIMISED();
  expect_energy_kept("conductor:alpha=0.3,eta=0.2,k=3.9");
}
TEST(TableEnergy, GlossyConductorKeepsItsAlbedo) {
  SKIP_UNLESS_OPTIMISED();
  expect_energy_kept("conductor:alpha=0.1,eta=0.2,k=3.9");
}
TEST(TableEnergy, SharperConductorKeepsItsAlbedo) {
  SKIP_UNLESS_OPTIMISED();
  expect_energy_kept("conductor:alpha=0.05,eta=0.2,k=3.9");
}

// The cause of the excess this grid removes: the same glossy lobe on a spherical grid of
// 5° in θ and 15° in φ reflects far more than falls on it at grazing incidence, and the
// writers say so, naming the angle.
TEST(TableEnergy, CoarseSphericalGridIsFlagged) {
  const auto model = make_bsdf("conductor:alpha=0.1,eta=0.2,k=3.9", WavelengthGrid::parse("550"));
  AngularGrid ag;
  ag.bilateral = true;
  ag.theta_i = ag.theta_o = tabtest::steps(0, 85, 5);
  ag.phi_o = tabtest::steps(0, 180, 15);
  const BsdfTable coarse = tabulate(*model, ag);
  EXPECT_GT(table_albedo(coarse, 85)[0], 2.5);
  EXPECT_NEAR(table_albedo(coarse, 85)[0], table_dense(coarse, 85)[0], 0.05);
  TabulatedParts parts;
  parts.brdf = coarse;
  std::ostringstream os;
  const auto w = write_ssdd(os, parts);
  ASSERT_FALSE(w.empty());
  EXPECT_NE(w.back().find("θi = 85°"), std::string::npos) << w.back();
  EXPECT_NE(os.str().find("# warning: brdf: directional reflectance"), std::string::npos);
}

// SSDD of the lobe-following table: what libbsdf and gonio read back reflects as the model.
TEST(TableEnergy, SsddKeepsTheAlbedoOfEveryChannel) {
  SKIP_UNLESS_OPTIMISED();
  const auto model = make_bsdf("conductor:alpha=0.1,eta=450:0.5,650:0.2,k=450:2.5,650:3.9",
                               WavelengthGrid::parse("450,550,650"));
  TabulatedParts parts;
  parts.brdf = tabulate_specular(*model, lobe_grid(*model));
  std::ostringstream os;
  SsddWriteOptions o;
  o.source = SsddSource::generated;
  EXPECT_TRUE(write_ssdd(os, parts, o).empty());
  EXPECT_NE(os.str().find("VERSION 0.3\n"), std::string::npos);
  EXPECT_NE(os.str().find("SOURCE_TYPE generated\n"), std::string::npos);
  EXPECT_EQ(os.str().find("NAME"), std::string::npos);
  std::istringstream in(os.str());
  const BsdfTable back = *read_ssdd(in).brdf;
  for (const double ti : {0.0, 60.0, 85.0}) {
    const auto m = model_dense(*model, ti), t = table_dense(back, ti);
    for (std::size_t c = 0; c < 3; ++c) EXPECT_NEAR(t[c] / m[c], 1.0, 0.02) << ti << " " << c;
  }
}

// Colour through IS-SA: the X, Y and Z blocks of the file, each read as a table and
// integrated, give the CIELAB of the model's directional reflectance within ΔE00 1.
TEST(TableColor, CielabRoundTripsThroughIssaXyz) {
  SKIP_UNLESS_OPTIMISED();
  const auto grid = WavelengthGrid::parse("400:700:10");
  const auto model = make_bsdf(
      "lambert:albedo=400:0.05,500:0.1,600:0.5,700:0.7+coat:alpha=0.1,ior=1.5", grid);
  const BsdfTable table = tabulate_specular(*model, lobe_grid(*model));
  const Colorimeter cm(grid);
  IssaWriteOptions o;
  std::array<std::vector<double>, 3> w;
  for (const auto& x : cm.weights()) {
    w[0].push_back(x.x / 100);
    w[1].push_back(x.y / 100);
    w[2].push_back(x.z / 100);
  }
  o.xyz_weights = w;
  std::ostringstream os;
  write_issa(os, table, false, o);
  const std::string text = os.str();
  ASSERT_NE(text.find("SpectralContent\tXYZ"), std::string::npos);
  // One Monochrome file per tristimulus block, header shared.
  const std::string header =
      text.substr(0, text.find("TristimulusX")).replace(text.find("XYZ"), 3, "Monochrome");
  std::array<BsdfTable, 3> xyz;
  const char* labels[3] = {"TristimulusX", "TristimulusY", "TristimulusZ"};
  for (int k = 0; k < 3; ++k) {
    const auto b = text.find(labels[k]) + std::string(labels[k]).size();
    const auto e = text.find("DataEnd", b) + 8;
    std::istringstream in(header + "Monochrome" + text.substr(b, e - b));
    xyz[static_cast<std::size_t>(k)] = *read_issa(in).brdf;
  }
  for (const double ti : {0.0, 30.0, 60.0, 85.0}) {
    SCOPED_TRACE(ti);
    const Lab want = cm.lab(model_dense(*model, ti));
    const Xyz got{100 * table_dense(xyz[0], ti)[0], 100 * table_dense(xyz[1], ti)[0],
                  100 * table_dense(xyz[2], ti)[0]};
    const Lab lab = xyz_to_lab(got, cm.white());
    EXPECT_LT(delta_e2000(want, lab), 1.0)
        << "model L*a*b* " << want.l << " " << want.a << " " << want.b << ", file " << lab.l
        << " " << lab.a << " " << lab.b;
    EXPECT_GT(std::hypot(want.a, want.b), 10);  // a coloured material indeed
  }
}

}  // namespace
}  // namespace gonio::twin
