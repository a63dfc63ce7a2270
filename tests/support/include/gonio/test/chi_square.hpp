// Pearson's chi-square test and the tail of its distribution, for the goodness-of-fit tests
// of the samplers (tests/unit/twin/bsdf, tests/unit/twin/tabulated): each bins its draws
// and the density its own way, and compares the counts here.
#pragma once

#include <string>
#include <vector>

namespace gonio::test {

// Regularised upper incomplete gamma function Q(a, x) = Γ(a, x)/Γ(a), a > 0.
double gamma_q(double a, double x);

// Probability that a chi-square variable with `dof` degrees of freedom exceeds x.
double chi2_sf(double x, double dof);

struct Pearson {
  double statistic = 0;
  double dof = 0;
  double p_value = 1;
  std::string worst;  // the cell that contributed most
};

// Observed against expected counts, cell by cell. Cells expected to hold fewer than 5 are
// pooled into one; draws in cells of zero expectation make the statistic infinite.
Pearson pearson(const std::vector<double>& observed, const std::vector<double>& expected);

}  // namespace gonio::test
