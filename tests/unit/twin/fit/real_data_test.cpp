// Fits on a table measured by another instrument (an imaging sphere, 2008; the shared real
// data set, see its README): it was not made by gonio, so it carries a real instrument's
// grid, noise and quirks. The table's own TIS lines are the reference.
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/twin/fit.hpp"

namespace gonio::twin {
namespace {

const std::string kTable =
    std::string(GONIO_SOURCE_DIR) + "/../shared/data/real/radiant-imaging-sphere-brdf.bsdf";

// The TIS the file states for its first block (15° incidence).
double first_tis() {
  std::ifstream in(kTable);
  std::string word;
  while (in >> word)
    if (word == "TIS") {
      double v = 0;
      in >> v;
      return v;
    }
  return 0;
}

const MeasuredData& table() {
  static const MeasuredData d = load_measured(kTable);
  return d;
}

TEST(RealTable, OnlyWhatTheTableCoversIsData) {
  ASSERT_TRUE(std::ifstream(kTable).good()) << kTable << " is missing";
  const auto& d = table();
  EXPECT_TRUE(d.exact_directions);
  EXPECT_GT(d.points.size(), 400u);
  EXPECT_LT(d.points.size(), 13u * 69u);  // geometries it does not cover are left out
  for (const auto& p : d.points) {
    EXPECT_GT(p.beta[0], 0) << p.geometry.to_string();
    // The radial axis ends 80° from the specular direction: 45/−40 lies 85° from it.
    EXPECT_FALSE(p.geometry.theta_i == 45 && p.geometry.theta_r == -40);
    // Tiny values get the absolute floor, not 1 % of themselves.
    EXPECT_GE(p.u[0], TableUncertainty{}.abs);
  }
}

TEST(RealTable, ALambertianFitAgreesWithTheTablesTis) {
  const double tis = first_tis();
  ASSERT_GT(tis, 0.1);
  const auto r = fit_material(table(), "lambert:albedo=?", InstrumentProfile::preset("gcms4"));
  ASSERT_EQ(r.parameters.size(), 1u);
  const double albedo = r.parameters[0].value;
  // In-plane points of a forward-scattering sample over-weight its lobe against the
  // hemisphere the TIS integrates: agreement to a quarter, not to the fit's u.
  EXPECT_NEAR(albedo, tis, 0.25 * tis) << r.to_json().dump(1);
  EXPECT_FALSE(r.parameters[0].at_bound);
  // No collapse onto the bound, and the misfit is said, with its worst regions.
  EXPECT_GT(r.chi2_per_dof, FitOptions{}.misfit_limit);
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_NE(r.warnings.front().find("does not describe the data"), std::string::npos);
  ASSERT_FALSE(r.misfit.empty());
  EXPECT_GE(r.misfit.front().theta_i, 60);  // the lobe grows toward grazing incidence
}

TEST(RealTable, OrenNayarReducesToTheLambertianFit) {
  const auto profile = InstrumentProfile::preset("gcms4");
  const auto l = fit_material(table(), "lambert:albedo=?", profile);
  const auto o = fit_material(table(), "oren-nayar:albedo=?,sigma=?", profile);
  // The sample is brighter toward the specular side, the opposite of a rough diffuser's
  // backscatter: σ goes to its lower bound, flagged, and the albedo is Lambert's.
  EXPECT_TRUE(o.parameters[1].at_bound);
  EXPECT_NEAR(o.parameters[0].value, l.parameters[0].value, 0.01 * l.parameters[0].value);
  bool flagged = false;
  for (const auto& w : o.warnings) flagged = flagged || w.find("oren-nayar.sigma") != std::string::npos;
  EXPECT_TRUE(flagged);
}

TEST(RealTable, TheAbgFitsTisAgreesWithTheTablesAndFitsBetterThanLambert) {
  const double tis = first_tis();
  const auto profile = InstrumentProfile::preset("gcms4");
  const auto a = fit_material(table(), "abg:A=?,B=?,g=?", profile);
  const auto l = fit_material(table(), "lambert:albedo=?", profile);
  ASSERT_EQ(a.parameters.size(), 3u);
  const double A = a.parameters[0].value, B = a.parameters[1].value, g = a.parameters[2].value;
  // TIS at 15° incidence: the integral of f over the unit disk of direction cosines with the
  // lobe centred at sin 15°, by a polar midpoint rule about the disk's centre.
  const double b0 = std::sin(15 * std::numbers::pi / 180);
  double s = 0;
  constexpr int kR = 800, kP = 720;
  for (int i = 0; i < kR; ++i) {
    const double r = (i + 0.5) / kR;
    for (int j = 0; j < kP; ++j) {
      const double phi = 2 * std::numbers::pi * (j + 0.5) / kP;
      const double d = std::hypot(r * std::cos(phi) - b0, r * std::sin(phi));
      s += A / (B + std::pow(d, g)) * r;
    }
  }
  s *= (1.0 / kR) * (2 * std::numbers::pi / kP);
  EXPECT_NEAR(s, tis, 0.25 * tis) << a.to_json().dump(1);
  EXPECT_LT(a.chi2_per_dof, l.chi2_per_dof);
}

}  // namespace
}  // namespace gonio::twin
