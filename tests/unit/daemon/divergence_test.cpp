// The divergence monitor's tests: z per channel, ΔE00, m of the last n, reference drift.
#include <cmath>

#include <gtest/gtest.h>

#include "gonio/daemon/divergence.hpp"

namespace gonio::daemon {
namespace {

TEST(Divergence, ZCombinesBothUncertaintiesAndTheTolerance) {
  const auto grid = WavelengthGrid::parse("500,600");
  const Spectrum m(grid, {1.10, 0.50}, {0.03, 0.01});
  const Spectrum p(grid, {1.00, 0.50}, {0.04, 0.00});
  DivergenceSettings s;
  s.z_threshold = 1.5;
  const auto d = evaluate_point(m, p, 0.0, nullptr, s);
  // Channel 0: 0.1 / √(0.03² + 0.04²) = 2.
  EXPECT_NEAR(d.z_max, 2.0, 1e-12);
  EXPECT_EQ(d.worst_channel, 0u);
  EXPECT_TRUE(d.diverged);
  EXPECT_FALSE(d.delta_e00.has_value());
  // A 12 % tolerance adds (0.12·1)² and brings z below the threshold: 0.1 / √(0.0025 + 0.0144).
  const auto t = evaluate_point(m, p, 0.12, nullptr, s);
  EXPECT_NEAR(t.z_max, 0.1 / std::sqrt(0.0025 + 0.0144), 1e-12);
  EXPECT_FALSE(t.diverged);
}

TEST(Divergence, ExactAgreementAndExactDisagreement) {
  const auto grid = WavelengthGrid::parse("550");
  DivergenceSettings s;
  EXPECT_EQ(evaluate_point(Spectrum(grid, {0.5}), Spectrum(grid, {0.5}), 0, nullptr, s).z_max, 0);
  const auto d = evaluate_point(Spectrum(grid, {0.5}), Spectrum(grid, {0.6}), 0, nullptr, s);
  EXPECT_TRUE(std::isfinite(d.z_max));
  EXPECT_TRUE(d.diverged);
}

TEST(Divergence, DeltaE00ZeroForEqualSpectraAndGrowsWithColour) {
  const auto grid = WavelengthGrid::visible();
  const auto cm = colorimeter_for(grid);
  ASSERT_NE(cm, nullptr);
  std::vector<double> grey(grid.size(), 0.4), warm(grid.size());
  for (std::size_t i = 0; i < grid.size(); ++i) warm[i] = 0.2 + 0.4 * (grid[i] - 400) / 300;
  const std::vector<double> u(grid.size(), 1.0);  // huge uncertainty: only ΔE can flag
  DivergenceSettings s;
  s.delta_e_threshold = 2;
  const auto same = evaluate_point(Spectrum(grid, grey, u), Spectrum(grid, grey, u), 0, cm.get(), s);
  EXPECT_NEAR(same.delta_e00.value(), 0, 1e-9);
  EXPECT_FALSE(same.diverged);
  const auto diff = evaluate_point(Spectrum(grid, warm, u), Spectrum(grid, grey, u), 0, cm.get(), s);
  EXPECT_GT(diff.delta_e00.value(), 2);
  EXPECT_LT(diff.z_max, 1);
  EXPECT_TRUE(diff.diverged);
  // An infrared-only grid carries no colour.
  EXPECT_EQ(colorimeter_for(WavelengthGrid::parse("1000:1500:100")), nullptr);
}

TEST(Divergence, SustainedIsMOfTheLastN) {
  SustainedWindow w(3, 5);
  EXPECT_FALSE(w.push(true));
  EXPECT_FALSE(w.push(false));
  EXPECT_FALSE(w.push(true));
  EXPECT_TRUE(w.push(true));   // 3 of the last 4
  EXPECT_TRUE(w.push(false));  // 3 of 5
  EXPECT_FALSE(w.push(false));  // the first diverged point left the window: 2 of 5
  EXPECT_EQ(w.diverged_in_window(), 2);
}

TEST(Divergence, ReferenceDrift) {
  EXPECT_NEAR(reference_drift({100, 100}, {103, 103}).value(), 0.03, 1e-12);
  EXPECT_NEAR(reference_drift({100, 100}, {95, 95}).value(), 0.05, 1e-12);
  EXPECT_FALSE(reference_drift({0, 0}, {1, 1}).has_value());
  EXPECT_FALSE(reference_drift({1}, {1, 1}).has_value());
}

}  // namespace
}  // namespace gonio::daemon
