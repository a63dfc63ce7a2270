// Q(a, x) by its series below x = a + 1 and by its continued fraction above (Abramowitz &
// Stegun 6.5.29 and 6.5.31), the fraction evaluated by the modified Lentz method.
#include "gonio/test/chi_square.hpp"

#include <cmath>

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

}  // namespace gonio::test
