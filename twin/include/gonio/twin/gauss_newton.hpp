// Bounded Gauss–Newton: a small least-squares minimiser for problems that bring their own
// normal equations (the verdict's fits, whose χ² is a quadratic form in an accumulated Gram
// matrix, daemon/include/gonio/daemon/instrument/verdict.hpp).
//
// Each iteration solves M δ = rhs by Cholesky (M the Gauss–Newton approximation of half the
// Hessian, rhs minus half the gradient), halves the step until χ² does not rise (quadratic
// terms can overshoot), and clamps to the box lo ≤ θ ≤ hi: a parameter that reaches a bound is
// held there (projected Gauss–Newton with an active set; Bertsekas 1982), and released once the
// fit has converged on the others if its descent points back inside.
//
// Matrices are n × n in column-major order (Eigen's, so a caller on Eigen copies or maps them);
// the header stays free of Eigen, whose include path only the fit family and the verdict use.
#pragma once

#include <cstddef>
#include <functional>
#include <limits>
#include <vector>

namespace gonio::twin {

struct GaussNewtonProblem {
  std::size_t parameters = 0;
  // χ²(θ).
  std::function<double(const std::vector<double>& theta)> objective;
  // The normal equations at θ: M (symmetric positive definite where solvable) and rhs.
  std::function<void(const std::vector<double>& theta, std::vector<double>& M, std::vector<double>& rhs)>
      normal_equations;
  // Per parameter (empty: unbounded); ±infinity for a side without bound.
  std::vector<double> lo, hi;
  std::vector<double> start;  // empty: zeros
  int max_iterations = 40;
  int max_halvings = 20;
};

struct GaussNewtonResult {
  bool solved = false;  // false: the first normal equations were not positive definite
  std::vector<double> theta;
  double chi2 = std::numeric_limits<double>::infinity();
  // M⁻¹ of the last normal equations solved, with the rows and columns of the parameters then
  // held at a bound set to the identity's (their own variance is 0: see at_bound).
  std::vector<double> inverse;
  std::vector<int> at_bound;  // −1, +1: held at lo / hi; 0: free
};

GaussNewtonResult bounded_gauss_newton(const GaussNewtonProblem& problem);

}  // namespace gonio::twin
