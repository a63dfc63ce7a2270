// The solver on problems with a known answer: a χ² with many local minima, where
// Levenberg–Marquardt from a poor start stops in the nearest one and the global start does
// not; the flags of a parameter pressed against its bound; the uncertainty of a misfit.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

// Private header of the fit family: the least-squares problem and its solver.
#include "gonio/twin/detail/fit/solver.hpp"

namespace gonio::twin::fit {
namespace {

// β_k(x) = cos(t_k x) at 40 abscissae t_k ∈ [0.2, 1]: χ² in x has a minimum every few units.
Problem wavy(double truth, double start) {
  Problem p;
  p.params = {{"x", start, 0, 20, false}};
  p.channel = {-1};
  p.group = {0};
  p.channels = 1;
  for (int k = 0; k < 40; ++k) {
    const double t = 0.2 + 0.8 * k / 39.0;
    p.measured.push_back(std::cos(t * truth));
    p.u.push_back(0.01);
  }
  p.evaluate = [](const std::vector<double>& x, std::vector<double>& beta, std::vector<double>& se) {
    beta.clear();
    for (int k = 0; k < 40; ++k) beta.push_back(std::cos((0.2 + 0.8 * k / 39.0) * x[0]));
    se.assign(beta.size(), 0.0);
  };
  return p;
}

TEST(GlobalStart, LeavesTheLocalMinimumOfAPoorStart) {
  auto p = wavy(15.0, 1.5);
  FitOptions o;
  const auto local = solve(p, o);
  ASSERT_GT(std::abs(local.parameters[0].value - 15.0), 1.0) << "the start must be a trap";
  EXPECT_GT(local.chi2, 100.0);
  const auto start = global_start(p, o);
  ASSERT_EQ(start.size(), 1u);
  p.params[0].start = start[0];
  const auto global = solve(p, o);
  EXPECT_NEAR(global.parameters[0].value, 15.0, 1e-6);
  EXPECT_LT(global.chi2, 1e-12);
}

TEST(GlobalStart, OneCandidateIsTheGivenStart) {
  const auto p = wavy(15.0, 1.5);
  FitOptions o;
  o.starts = 1;
  EXPECT_EQ(global_start(p, o), std::vector<double>{1.5});
}

TEST(Solve, AParameterNearItsBoundIsFlaggedWithAWarning) {
  // The data want x = −1, outside [0, 20]: the optimum presses against 0.
  auto p = wavy(15.0, 3.0);
  p.evaluate = [](const std::vector<double>& x, std::vector<double>& beta, std::vector<double>& se) {
    beta.assign(40, x[0]);
    se.assign(40, 0.0);
  };
  p.measured.assign(40, -1.0);
  const auto r = solve(p, FitOptions{});
  EXPECT_TRUE(r.parameters[0].at_bound);
  EXPECT_LT(r.parameters[0].value, 0.1);
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_NE(r.warnings.front().find("is at a bound"), std::string::npos) << r.warnings.front();
}

TEST(Solve, PerChannelParametersOnABoundAreOneWarning) {
  // Three channels each with its own parameter, two pushed below 0.
  Problem p;
  for (int c = 0; c < 3; ++c) {
    p.params.push_back({"lambert.albedo@" + std::to_string(400 + 100 * c), 0.5, 0, 1, false});
    p.channel.push_back(c);
    p.group.push_back(0);
  }
  p.channels = 3;
  const double want[3] = {-0.2, 0.4, -0.3};
  for (int k = 0; k < 10; ++k)
    for (int c = 0; c < 3; ++c) {
      p.measured.push_back(want[c]);
      p.u.push_back(0.01);
    }
  p.evaluate = [](const std::vector<double>& x, std::vector<double>& beta, std::vector<double>& se) {
    beta.clear();
    for (int k = 0; k < 10; ++k)
      for (int c = 0; c < 3; ++c) beta.push_back(x[static_cast<std::size_t>(c)]);
    se.assign(beta.size(), 0.0);
  };
  const auto r = solve(p, FitOptions{});
  int bound_warnings = 0;
  for (const auto& w : r.warnings)
    if (w.find("is at a bound") != std::string::npos) {
      ++bound_warnings;
      EXPECT_NE(w.find("at 2 of 3 channels"), std::string::npos) << w;
    }
  EXPECT_EQ(bound_warnings, 1);
  EXPECT_NEAR(r.parameters[1].value, 0.4, 1e-4);
}

// A model that misses the same way in every channel of a geometry: a level μ fitted to
// geometries whose true values scatter by d_g about it, alike in all C channels, read with
// u = 1. The honest u of μ is the standard error of the mean over geometries,
// s_d/√G; √(χ²/dof) counts the C channels as independent and gives about 1/√C of it. The
// solver's cluster-robust covariance gives s_d/√G exactly; a fit that does not miss keeps
// √(χ²/dof).
TEST(Solve, AMisfitsUncertaintyComesFromTheScatterOfItsGeometries) {
  static constexpr int G = 40, C = 8;
  const auto level = [&](double spread) {
    Problem p;
    p.params = {{"mu", 0.5, -10, 10, false}};
    p.channel = {-1};
    p.group = {0};
    p.channels = C;
    for (int g = 0; g < G; ++g)
      for (int k = 0; k < C; ++k) {
        p.measured.push_back(1 + spread * std::sin(1.7 * g) + 0.3 * std::cos(2.3 * (g * C + k)));
        p.u.push_back(1);
      }
    p.evaluate = [](const std::vector<double>& x, std::vector<double>& beta, std::vector<double>& se) {
      beta.assign(G * C, x[0]);
      se.assign(beta.size(), 0.0);
    };
    return p;
  };
  const auto misfit = level(4);
  double mean = 0, ss = 0;
  std::vector<double> per(G, 0);
  for (int g = 0; g < G; ++g) {
    for (int k = 0; k < C; ++k) per[g] += misfit.measured[static_cast<std::size_t>(g * C + k)] / C;
    mean += per[g] / G;
  }
  for (const double v : per) ss += (v - mean) * (v - mean);
  const double sem = std::sqrt(ss / (G - 1) / G);
  const auto r = solve(misfit, FitOptions{});
  ASSERT_GT(r.chi2_per_dof, 2);
  EXPECT_NEAR(r.parameters[0].value, mean, 1e-6);
  EXPECT_NEAR(r.parameters[0].u, sem, 1e-4 * sem);
  auto birge_only = FitOptions{};
  birge_only.misfit_limit = 1e6;  // widening applies to misfits only
  const auto b = solve(misfit, birge_only);
  EXPECT_NEAR(b.parameters[0].u, std::sqrt(r.chi2_per_dof / (G * C)), 1e-6);
  EXPECT_GT(r.parameters[0].u, 2 * b.parameters[0].u) << "√(χ²/dof) would understate it about √C times";
  // Noise alone (χ²/dof ≤ the limit): u as before.
  const auto fits = solve(level(0), FitOptions{});
  ASSERT_LT(fits.chi2_per_dof, 2);
  EXPECT_NEAR(fits.parameters[0].u, std::sqrt(std::max(1.0, fits.chi2_per_dof) / (G * C)), 1e-6);
}

}  // namespace
}  // namespace gonio::twin::fit
