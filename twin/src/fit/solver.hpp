// The weighted least-squares problem shared by the material fit and the calibration, and
// its solution by Levenberg–Marquardt with covariance and identifiability analysis.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "gonio/twin/fit.hpp"

namespace gonio::twin::fit {

struct Problem {
  std::vector<FreeParameter> params;
  // Per parameter: the wavelength channel it alone acts on (−1: all), and its group:
  // parameters of one group act on disjoint channels and share one Jacobian evaluation
  // (Curtis, Powell & Reid 1974).
  std::vector<int> channel, group;
  std::size_t channels = 0;
  std::vector<double> measured, u;  // point-major, channel fastest
  // The model at parameter values x: β and its standard error at every residual.
  std::function<void(const std::vector<double>& x, std::vector<double>& beta,
                     std::vector<double>& se)> evaluate;
};

// Minimises Σ ((β(x) − m) / √(u² + se²))². Fills parameters, correlation, χ², dof,
// iterations, evaluations, converged, status, warnings, degenerate (not points, seconds,
// kind, spec).
FitResult solve(const Problem& problem, const FitOptions& options);

}  // namespace gonio::twin::fit
