// The bounded Gauss–Newton on problems with a known answer: a straight line through exact
// points (one step, and its inverse normal matrix the parameters' covariance), the same line
// with its slope bounded below the truth (held at the bound, the intercept the mean of what
// is left), an exponential (several steps), a bound met on the way but not at the optimum
// (released), and a problem with no information (not solved).
#include <cmath>
#include <functional>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "gonio/twin/gauss_newton.hpp"

namespace gonio::twin {
namespace {

// Least squares of y_k against the model m(θ, x_k) with its gradient, as the solver takes it:
// χ² = Σ (y − m)², M = JᵀJ (column-major), rhs = Jᵀ(y − m).
using Gradient = std::vector<double>;
struct Curve {
  std::vector<double> x, y;
  std::function<double(const std::vector<double>&, double)> model;
  std::function<Gradient(const std::vector<double>&, double)> gradient;

  GaussNewtonProblem problem(std::size_t n) const {
    GaussNewtonProblem p;
    p.parameters = n;
    p.objective = [this](const std::vector<double>& th) {
      double chi2 = 0;
      for (std::size_t k = 0; k < x.size(); ++k) chi2 += std::pow(y[k] - model(th, x[k]), 2);
      return chi2;
    };
    p.normal_equations = [this, n](const std::vector<double>& th, std::vector<double>& M, std::vector<double>& rhs) {
      M.assign(n * n, 0.0);
      rhs.assign(n, 0.0);
      for (std::size_t k = 0; k < x.size(); ++k) {
        const auto g = gradient(th, x[k]);
        const double r = y[k] - model(th, x[k]);
        for (std::size_t i = 0; i < n; ++i) {
          rhs[i] += g[i] * r;
          for (std::size_t j = 0; j < n; ++j) M[j * n + i] += g[i] * g[j];
        }
      }
    };
    return p;
  }
};

Curve line(double a, double b) {
  Curve c;
  for (int k = 0; k < 5; ++k) {
    c.x.push_back(k);
    c.y.push_back(a + b * k);
  }
  c.model = [](const std::vector<double>& th, double x) { return th[0] + th[1] * x; };
  c.gradient = [](const std::vector<double>&, double x) { return Gradient{1.0, x}; };
  return c;
}

TEST(BoundedGaussNewton, FitsALineInOneStepWithItsCovariance) {
  const auto c = line(2.0, -0.5);
  const auto r = bounded_gauss_newton(c.problem(2));
  ASSERT_TRUE(r.solved);
  EXPECT_NEAR(r.theta[0], 2.0, 1e-12);
  EXPECT_NEAR(r.theta[1], -0.5, 1e-12);
  EXPECT_NEAR(r.chi2, 0.0, 1e-20);
  // x = 0…4: JᵀJ = [[5, 10], [10, 30]], its inverse [[0.6, −0.2], [−0.2, 0.1]].
  EXPECT_NEAR(r.inverse[0], 0.6, 1e-12);
  EXPECT_NEAR(r.inverse[2], -0.2, 1e-12);
  EXPECT_NEAR(r.inverse[3], 0.1, 1e-12);
  EXPECT_EQ(r.at_bound, (std::vector<int>{0, 0}));
}

TEST(BoundedGaussNewton, HoldsAParameterAtItsBound) {
  const auto c = line(2.0, -0.5);
  auto p = c.problem(2);
  const double inf = std::numeric_limits<double>::infinity();
  p.lo = {-inf, -0.2};
  p.hi = {inf, inf};
  const auto r = bounded_gauss_newton(p);
  ASSERT_TRUE(r.solved);
  EXPECT_EQ(r.at_bound, (std::vector<int>{0, -1}));
  EXPECT_DOUBLE_EQ(r.theta[1], -0.2);
  // The slope held at −0.2: the intercept is the mean of y − (−0.2)x = 2 − 0.3x over x = 0…4.
  EXPECT_NEAR(r.theta[0], 2.0 - 0.3 * 2, 1e-12);
  // χ² = Σ (−0.3(x − 2))² = 0.09 · 10.
  EXPECT_NEAR(r.chi2, 0.9, 1e-12);
}

TEST(BoundedGaussNewton, ConvergesOnAnExponential) {
  Curve c;
  for (int k = 0; k < 8; ++k) {
    c.x.push_back(0.5 * k);
    c.y.push_back(1.5 * std::exp(0.7 * 0.5 * k));
  }
  c.model = [](const std::vector<double>& th, double x) { return th[0] * std::exp(th[1] * x); };
  c.gradient = [](const std::vector<double>& th, double x) {
    return Gradient{std::exp(th[1] * x), th[0] * x * std::exp(th[1] * x)};
  };
  auto p = c.problem(2);
  p.start = {1.0, 0.0};
  const auto r = bounded_gauss_newton(p);
  ASSERT_TRUE(r.solved);
  EXPECT_NEAR(r.theta[0], 1.5, 1e-9);
  EXPECT_NEAR(r.theta[1], 0.7, 1e-9);
  EXPECT_LT(r.chi2, 1e-15);
}

// y = x·θ² with θ = 1: from θ = 0.6 the first Gauss–Newton step (δ = (1 − θ²)/(2θ)) overshoots
// to 1.133, past the bound 1.1, where χ² is lower than at the start: held there, then released
// as the descent points back inside, and the fit ends at 1.
TEST(BoundedGaussNewton, ReleasesABoundMetOnTheWay) {
  Curve c;
  for (int k = 1; k <= 4; ++k) {
    c.x.push_back(k);
    c.y.push_back(k * 1.0);
  }
  c.model = [](const std::vector<double>& th, double x) { return x * th[0] * th[0]; };
  c.gradient = [](const std::vector<double>& th, double x) {
    return Gradient{2 * x * th[0]};
  };
  auto p = c.problem(1);
  p.start = {0.6};
  p.lo = {-1.1};
  p.hi = {1.1};
  const auto r = bounded_gauss_newton(p);
  ASSERT_TRUE(r.solved);
  EXPECT_EQ(r.at_bound, (std::vector<int>{0}));
  EXPECT_NEAR(r.theta[0], 1.0, 1e-9);
}

TEST(BoundedGaussNewton, AProblemWithoutInformationIsNotSolved) {
  auto c = line(1.0, 1.0);
  c.gradient = [](const std::vector<double>&, double) { return Gradient{1.0, 0.0}; };
  const auto r = bounded_gauss_newton(c.problem(2));
  EXPECT_FALSE(r.solved);
  EXPECT_TRUE(std::isinf(r.chi2));
}

}  // namespace
}  // namespace gonio::twin
