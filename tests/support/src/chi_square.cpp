// Q(a, x) by its series below x = a + 1 and by its continued fraction above (Abramowitz &
// Stegun 6.5.29 and 6.5.31), the fraction evaluated by the modified Lentz method.
#include "gonio/test/chi_square.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace gonio::test {

double gamma_q(double a, double x) {
  if (x <= 0) return 1;
  const double log_front = a * std::log(x) - x - std::lgamma(a);
  if (x < a + 1) {
    double term = 1 / a, sum = term;
    for (int n = 1; n < 10000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-16) break;
    }
    const double p = sum * std::exp(log_front);
    return p >= 1 ? 0.0 : 1 - p;
  }
  constexpr double tiny = 1e-300;
  double b = x + 1 - a, c = 1 / tiny, d = 1 / b, h = d;
  for (int i = 1; i < 10000; ++i) {
    const double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1) < 1e-16) break;
  }
  const double q = std::exp(log_front) * h;
  return q > 1 ? 1.0 : q;
}

double chi2_sf(double x, double dof) { return gamma_q(dof / 2, x / 2); }

Pearson pearson(const std::vector<double>& observed, const std::vector<double>& expected) {
  Pearson r;
  double pool_obs = 0, pool_exp = 0, worst = -1;
  int cells = 0;
  for (std::size_t k = 0; k < expected.size(); ++k) {
    if (expected[k] < 5) {
      pool_obs += observed[k];
      pool_exp += expected[k];
      continue;
    }
    const double d = observed[k] - expected[k];
    const double c = d * d / expected[k];
    if (c > worst) {
      worst = c;
      r.worst = "cell " + std::to_string(k) + ": observed " + std::to_string(observed[k]) +
                ", expected " + std::to_string(expected[k]);
    }
    r.statistic += c;
    ++cells;
  }
  if (pool_exp > 0) {
    const double d = pool_obs - pool_exp;
    r.statistic += d * d / pool_exp;
    ++cells;
  } else if (pool_obs > 0) {
    r.statistic = std::numeric_limits<double>::infinity();
    r.worst = "draws where the pdf integrates to zero";
  }
  r.dof = std::max(1, cells - 1);
  r.p_value = chi2_sf(r.statistic, r.dof);
  return r;
}

}  // namespace gonio::test
