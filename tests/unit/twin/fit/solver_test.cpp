// The solver on problems with a known answer: a χ² with many local minima, where
// Levenberg–Marquardt from a poor start stops in the nearest one and the global start does
// not; and the flags of a parameter pressed against its bound.
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

}  // namespace
}  // namespace gonio::twin::fit
