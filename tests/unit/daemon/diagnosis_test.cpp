// The diagnosis's pure parts: χ²/dof of stored points, and which candidate explains a
// divergence (diagnosis.hpp). The fits themselves are tested in twin/fit and end to end in
// the integration tests.
#include "gonio/daemon/diagnosis.hpp"

#include <gtest/gtest.h>

namespace gonio::daemon {
namespace {

twin::FitResult candidate(const std::string& name, double value, double u, double chi2) {
  twin::FitResult f;
  f.kind = "calibrate";
  f.converged = true;
  f.chi2_per_dof = chi2;
  twin::FittedParameter p;
  p.name = name;
  p.value = value;
  p.u = u;
  p.lo = value - 10, p.hi = value + 10;
  f.parameters.push_back(p);
  return f;
}

PointRecord point(std::vector<double> m, std::vector<double> u, std::optional<std::vector<double>> p,
                  std::vector<double> s = {}) {
  PointRecord r;
  const auto grid = WavelengthGrid::parse("450,550,650", "wavelengths");
  r.measured = Spectrum(grid, std::move(m), std::move(u));
  if (p) r.predicted = Spectrum(grid, std::move(*p), s.empty() ? std::vector<double>(3, 0.0) : std::move(s));
  return r;
}

TEST(Chi2PerDof, WeighsByBothUncertaintiesAndSkipsPointsWithoutPrediction) {
  // (0.1² / (0.03² + 0.04²)) = 4 per channel; the point without a prediction does not count.
  const std::vector<PointRecord> pts{
      point({1.1, 1.1, 1.1}, {0.03, 0.03, 0.03}, std::vector<double>{1, 1, 1}, {0.04, 0.04, 0.04}),
      point({5, 5, 5}, {0.1, 0.1, 0.1}, std::nullopt)};
  const auto c = chi2_per_dof(pts);
  ASSERT_TRUE(c.has_value());
  EXPECT_NEAR(*c, 4.0, 1e-9);
  EXPECT_FALSE(chi2_per_dof({point({1, 1, 1}, {0.1, 0.1, 0.1}, std::nullopt)}).has_value());
}

TEST(Explain, NamesTheCandidateThatBringsChi2DownToTheNoise) {
  const std::vector<twin::FitResult> c{candidate("receive_offset_deg", -0.21, 0.02, 1.1),
                                       candidate("incidence_offset_deg", 0.4, 0.1, 9.0),
                                       candidate("gain", 1.04, 0.01, 12.0)};
  const auto v = explain(38, c);
  EXPECT_TRUE(v.explained);
  ASSERT_TRUE(v.best.has_value());
  EXPECT_EQ(*v.best, 0u);
  EXPECT_TRUE(v.alike.empty());
  EXPECT_NE(v.text.find("consistent with a receive-arm offset of -0.210 ± 0.020°"), std::string::npos) << v.text;
  EXPECT_NE(v.text.find("38 → 1.1"), std::string::npos) << v.text;
}

TEST(Explain, NamesEveryCandidateTheDataCannotTellApart) {
  // An incidence and a receive offset shift a specular peak alike.
  const std::vector<twin::FitResult> c{candidate("receive_offset_deg", -0.2, 0.02, 1.2),
                                       candidate("incidence_offset_deg", 0.2, 0.02, 1.0),
                                       candidate("gain", 1.1, 0.01, 15.0)};
  const auto v = explain(40, c);
  ASSERT_TRUE(v.explained);
  EXPECT_EQ(*v.best, 1u);
  ASSERT_EQ(v.alike.size(), 1u);
  EXPECT_EQ(v.alike[0], 0u);
  EXPECT_NE(v.text.find("equally with a receive-arm offset"), std::string::npos) << v.text;
}

TEST(Explain, ABetterButStillPoorFitIsNoExplanation) {
  // χ²/dof falls from 40 to 6: better, but far from the noise; and a fit that barely helps.
  EXPECT_FALSE(explain(40, {candidate("gain", 1.1, 0.01, 6.0)}).explained);
  EXPECT_FALSE(explain(2.5, {candidate("gain", 1.01, 0.01, 1.5)}).explained);
  const auto v = explain(40, {candidate("gain", 1.1, 0.01, 6.0)});
  EXPECT_NE(v.text.find("sample may differ"), std::string::npos) << v.text;
}

TEST(Explain, UnusableFitsAreNeverTheAnswer) {
  auto at_bound = candidate("receive_offset_deg", -5, 0.1, 0.9);
  at_bound.parameters[0].at_bound = true;
  auto not_converged = candidate("incidence_offset_deg", 0.1, 0.1, 0.8);
  not_converged.converged = false;
  auto flat = candidate("gain", 1.0, 0.5, 0.7);
  flat.parameters[0].identifiable = false;
  const auto v = explain(30, {at_bound, not_converged, flat});
  EXPECT_FALSE(v.explained);
  EXPECT_FALSE(v.best.has_value());
  EXPECT_NE(v.text.find("could be fitted"), std::string::npos) << v.text;
}

TEST(Explain, AFitThatDidNotConstrainItsParameterIsNoAnswer) {
  // A one-parameter fit that stayed where it started, its uncertainty wider than its range.
  auto loose = candidate("receive_offset_deg", 0.0, 9.7e11, 3700);
  loose.parameters[0].lo = -5, loose.parameters[0].hi = 5;
  const auto v = explain(3700, {loose});
  EXPECT_FALSE(v.best.has_value());
  EXPECT_EQ(v.text.find("receive-arm offset of"), std::string::npos) << v.text;
}

TEST(Explain, SaysWhenTheBestFitIsAtTheEndOfItsRange) {
  // A sample twice as bright as its reference: the gain runs to its bound of 2 and fits
  // better than anything else, which the verdict must not hide behind a poorer candidate.
  auto gain = candidate("gain", 2.0, 0.001, 1.1);
  gain.parameters[0].at_bound = true;
  const auto v = explain(3700, {candidate("receive_offset_deg", 0.01, 0.02, 3600), gain});
  EXPECT_FALSE(v.explained);
  EXPECT_NE(v.text.find("reference-white gain at the end of its range (2)"), std::string::npos) << v.text;
  EXPECT_EQ(v.text.find("best: a receive-arm offset"), std::string::npos) << v.text;
  // A usable candidate that explains it still wins.
  const auto w = explain(3700, {candidate("receive_offset_deg", 0.2, 0.02, 1.2), gain});
  EXPECT_TRUE(w.explained);
  EXPECT_NE(w.text.find("consistent with a receive-arm offset"), std::string::npos) << w.text;
}

}  // namespace
}  // namespace gonio::daemon
