// The per-point decision rule (ISO 14253-1 / JCGM 106 guarded acceptance and rejection), its
// colour checks with their propagated uncertainty, and reference drift.
#include <cmath>

#include <gtest/gtest.h>

#include "gonio/daemon/instrument/divergence.hpp"

namespace gonio::daemon {
namespace {

const std::vector<double> kNone;
const std::vector<BudgetEntry> kNoBudget;

TEST(DecisionRule, ToleranceIsALimitGuardedByKTimesU) {
  // T = 0.02; k = 2.
  EXPECT_EQ(decide(0.010, 0.004, 0.02, 2), Decision::agrees);            // 0.018 ≤ 0.02
  EXPECT_EQ(decide(-0.013, 0.004, 0.02, 2), Decision::undecided);        // 0.021 > 0.02, 0.005 ≤ 0.02
  EXPECT_EQ(decide(0.027, 0.004, 0.02, 2), Decision::undecided);         // 0.019 ≤ 0.02 < 0.035
  EXPECT_EQ(decide(0.030, 0.004, 0.02, 2), Decision::out_of_tolerance);  // 0.022 > 0.02
  EXPECT_EQ(decide(0.030, 0.004, 0.02, 1), Decision::out_of_tolerance);  // 0.026 > 0.02
  EXPECT_EQ(decide(0.0, 0.0, 0.0, 2), Decision::agrees);
  EXPECT_EQ(worse(Decision::agrees, Decision::undecided), Decision::undecided);
  EXPECT_EQ(worse(Decision::out_of_tolerance, Decision::undecided), Decision::out_of_tolerance);
}

TEST(Divergence, AConsistentFourPercentShiftIsOutOfATwoPercentTolerance) {
  const auto grid = WavelengthGrid::parse("500,600");
  DivergenceSettings s;
  const Spectrum p(grid, {0.50, 0.50}, {0.0005, 0.0005});
  // +4 % with u_c ≈ 0.1 %: |d| − 2u_c = 0.019 > 0.01.
  const auto out = evaluate_point(Spectrum(grid, {0.52, 0.52}, {0.0005, 0.0005}), p, kNone, kNoBudget, 0.02, nullptr, s);
  EXPECT_EQ(out.decision, Decision::out_of_tolerance);
  EXPECT_TRUE(out.diverged);
  // +1 %: |d| + 2u_c = 0.0064 ≤ 0.01.
  const auto in = evaluate_point(Spectrum(grid, {0.505, 0.50}, {0.0005, 0.0005}), p, kNone, kNoBudget, 0.02, nullptr, s);
  EXPECT_EQ(in.decision, Decision::agrees);
  EXPECT_FALSE(in.diverged);
  // The same +4 % when the twin's budget says the prediction is only good to 2 %: undecided.
  const auto wide = evaluate_point(Spectrum(grid, {0.52, 0.52}, {0.0005, 0.0005}), p, {0.01, 0.01}, kNoBudget,
                                   0.02, nullptr, s);
  EXPECT_EQ(wide.decision, Decision::undecided);
  // z is d/u_c without the tolerance: 0.02 / √(0.0005² · 2 + 0.01²).
  EXPECT_NEAR(wide.z_max, 0.02 / std::sqrt(2 * 0.0005 * 0.0005 + 1e-4), 1e-9);
}

TEST(Divergence, ExactAgreementAndExactDisagreement) {
  const auto grid = WavelengthGrid::parse("550");
  DivergenceSettings s;
  const auto same = evaluate_point(Spectrum(grid, {0.5}), Spectrum(grid, {0.5}), kNone, kNoBudget, 0, nullptr, s);
  EXPECT_EQ(same.z_max, 0);
  EXPECT_EQ(same.decision, Decision::agrees);
  const auto d = evaluate_point(Spectrum(grid, {0.5}), Spectrum(grid, {0.6}), kNone, kNoBudget, 0, nullptr, s);
  EXPECT_TRUE(std::isfinite(d.z_max));
  EXPECT_TRUE(d.diverged);
  EXPECT_TRUE(d.inconsistent);
}

TEST(Divergence, CiedeWhereLabIsDefinedWithItsOwnUncertainty) {
  const auto grid = WavelengthGrid::visible();
  const auto cm = colorimeter_for(grid);
  ASSERT_NE(cm, nullptr);
  std::vector<double> grey(grid.size(), 0.4), warm(grid.size());
  for (std::size_t i = 0; i < grid.size(); ++i) warm[i] = 0.2 + 0.4 * (grid[i] - 400) / 300;
  DivergenceSettings s;
  s.delta_e_threshold = 2;
  const std::vector<double> small(grid.size(), 1e-4);
  const auto same = evaluate_point(Spectrum(grid, grey, small), Spectrum(grid, grey, small), kNone, kNoBudget,
                                   0.5, cm.get(), s);
  ASSERT_TRUE(same.color.has_value());
  EXPECT_EQ(same.color->kind, "ciede2000");
  EXPECT_NEAR(same.delta_e00.value(), 0, 1e-9);
  EXPECT_EQ(same.decision, Decision::agrees);
  // A warm against a grey spectrum: ΔE00 far beyond 2 with a small u, while the spectral
  // tolerance (50 %) lets every channel pass: the colour alone rejects it.
  const auto diff = evaluate_point(Spectrum(grid, warm, small), Spectrum(grid, grey, small), kNone, kNoBudget,
                                   0.5, cm.get(), s);
  EXPECT_GT(diff.delta_e00.value(), 2);
  EXPECT_GT(diff.color->u, 0);
  EXPECT_LT(diff.color->u, 0.1);
  EXPECT_EQ(diff.color->decision, "out_of_tolerance");
  EXPECT_EQ(diff.decision, Decision::out_of_tolerance);
  // The same spectra with a large uncertainty: the colour difference is not decidable.
  const std::vector<double> big(grid.size(), 0.2);
  const auto noisy = evaluate_point(Spectrum(grid, warm, big), Spectrum(grid, grey, big), kNone, kNoBudget, 0.5,
                                    cm.get(), s);
  EXPECT_GT(noisy.color->u, 5);
  EXPECT_NE(noisy.color->decision, "out_of_tolerance") << noisy.delta_e00.value() << " ± " << noisy.color->u;
  // An infrared-only grid carries no colour.
  EXPECT_EQ(colorimeter_for(WavelengthGrid::parse("1000:1500:100")), nullptr);
}

TEST(Divergence, AboveTheDiffuserChromaticityAndLuminanceApartNotCiede) {
  // β = 6 on a glossy peak: L* far above 100, where ΔE00 is meaningless. A 1.4 % change in
  // one channel of 31, well within a 2 % tolerance, must not be a colour difference.
  const auto grid = WavelengthGrid::visible();
  const auto cm = colorimeter_for(grid);
  std::vector<double> p(grid.size(), 6.0), m = p;
  m[15] *= 1.014;
  const std::vector<double> u(grid.size(), 0.006);
  DivergenceSettings s;
  const auto d = evaluate_point(Spectrum(grid, m, u), Spectrum(grid, p, u), kNone, kNoBudget, 0.02, cm.get(), s);
  ASSERT_TRUE(d.color.has_value());
  EXPECT_EQ(d.color->kind, "chromaticity");
  EXPECT_FALSE(d.delta_e00.has_value());
  EXPECT_LT(d.color->difference, 0.002);
  EXPECT_NEAR(d.color->luminance_ratio.value(), 1.0, 0.002);
  EXPECT_NE(d.decision, Decision::out_of_tolerance);
  // A 10 % brighter peak (all channels): the luminance is out of a 2 % tolerance.
  std::vector<double> bright = p;
  for (auto& b : bright) b *= 1.1;
  const auto l = evaluate_point(Spectrum(grid, bright, u), Spectrum(grid, p, u), kNone, kNoBudget, 0.02, cm.get(), s);
  EXPECT_EQ(l.color->decision, "out_of_tolerance");
}

TEST(Divergence, ACorrelatedBudgetComponentMovesTheColorLessThanIndependentNoise) {
  // A gain-like component moves every channel together: it changes luminance, not
  // chromaticity, so Δu′v′'s uncertainty stays small while Y's grows.
  const auto grid = WavelengthGrid::visible();
  const auto cm = colorimeter_for(grid);
  std::vector<double> p(grid.size(), 3.0);
  const std::vector<double> tiny(grid.size(), 1e-6);
  BudgetEntry gain{"reference_white_rel", "normal", "1", false, {0.01}, p, std::vector<double>(grid.size(), 0.03), {}, {}, {}};
  DivergenceSettings s;
  const auto d = evaluate_point(Spectrum(grid, p, tiny), Spectrum(grid, p, tiny), std::vector<double>(grid.size(), 0.03),
                                {gain}, 0.02, cm.get(), s);
  EXPECT_LT(d.color->u, 1e-4);
  EXPECT_NEAR(d.color->luminance_u.value(), 0.01, 1e-3);
}

TEST(Divergence, ReferenceDrift) {
  EXPECT_NEAR(reference_drift({100, 100}, {103, 103}).value(), 0.03, 1e-12);
  EXPECT_NEAR(reference_drift({100, 100}, {95, 95}).value(), 0.05, 1e-12);
  EXPECT_FALSE(reference_drift({0, 0}, {1, 1}).has_value());
  EXPECT_FALSE(reference_drift({1}, {1, 1}).has_value());
}

}  // namespace
}  // namespace gonio::daemon
