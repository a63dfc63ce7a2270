// The tail of the chi-square distribution, for the p-values of the goodness-of-fit tests
// of the samplers (tests/unit/twin/bsdf, tests/unit/twin/tabulated).
#pragma once

namespace gonio::test {

// Regularised upper incomplete gamma function Q(a, x) = Γ(a, x)/Γ(a), a > 0.
double gamma_q(double a, double x);

// Probability that a chi-square variable with `dof` degrees of freedom exceeds x.
double chi2_sf(double x, double dof);

}  // namespace gonio::test
