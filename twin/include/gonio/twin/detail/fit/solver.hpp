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
  // Optional: the model at xs[0] and at the stepped points xs[1…] at once, the steps on the
  // first point's random numbers (the twin's variants), so that a Jacobian's differences
  // carry no Monte Carlo noise of their own and share the paths' cost. beta[0] and se[0]
  // must equal what evaluate(xs[0]) gives.
  std::function<void(const std::vector<std::vector<double>>& xs,
                     std::vector<std::vector<double>>& beta,
                     std::vector<std::vector<double>>& se)> evaluate_steps;
};

// Minimises Σ ((β(x) − m) / √(u² + se²))². Fills parameters, correlation, χ², dof,
// iterations, evaluations, converged, status, warnings, degenerate (not points, seconds,
// kind, spec). `at`, when given, receives the model and the normalised residuals there.
struct Optimum {
  std::vector<double> beta, z;  // per residual: fitted β, (β − measured) / σ
};
FitResult solve(const Problem& problem, const FitOptions& options, Optimum* at = nullptr);

// The regions of `data` (incidence × part of the receiving range) ordered by their share
// of χ², worst first, at most `limit`.
std::vector<MisfitRegion> misfit_regions(const MeasuredData& data, const Optimum& at,
                                         std::size_t limit = 5);
// The warning for a fit whose χ²/dof exceeds the limit, quoting its worst regions.
std::string misfit_warning(const FitResult& r);

// A start for the parameters that act on every channel, found before the local fit so
// that a poor guess does not end in a degenerate corner: the given start and
// options.starts − 1 points of a Sobol sequence over the bounded space (in the
// parameters' fitting coordinates) each get a short Levenberg–Marquardt run of every
// parameter, and the lowest χ² wins. Returns the start values of every parameter.
std::vector<double> global_start(const Problem& problem, const FitOptions& options);

}  // namespace gonio::twin::fit
