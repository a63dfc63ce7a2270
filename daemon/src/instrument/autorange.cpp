// Auto-ranging decisions (autorange.hpp).
#include "gonio/daemon/instrument/autorange.hpp"

#include <algorithm>
#include <cmath>

namespace gonio::daemon {

double best_channel_snr(const drivers::Reading& sample, const drivers::Reading& dark) {
  const auto& S = sample.spectrum;
  const auto& D = dark.spectrum;
  const std::size_t n = std::min(S.values.size(), D.values.size());
  double best = 0;
  for (std::size_t c = 0; c < n; ++c) {
    const double us = c < S.std_uncertainty.size() ? S.std_uncertainty[c] : 0.0;
    const double ud = c < D.std_uncertainty.size() ? D.std_uncertainty[c] : 0.0;
    const double u = std::hypot(us, ud);
    const double net = S.values[c] - D.values[c];
    // A noiseless channel (no uncertainty reported) with signal is well exposed.
    const double snr = u > 0 ? net / u : (net > 0 ? HUGE_VAL : 0.0);
    best = std::max(best, snr);
  }
  return best;
}

std::optional<double> next_integration_ms(double t_ms, bool saturated, double snr,
                                          std::optional<double> ceiling_ms, const RangeLimits& lim) {
  // Relative slack, so that a setting the device rounds is still taken as the limit.
  constexpr double kSlack = 1e-9;
  if (saturated) {
    if (t_ms <= lim.min_ms * (1 + kSlack)) return std::nullopt;
    return std::max(lim.min_ms, t_ms / kRangeStep);
  }
  if (snr >= lim.underexposed_snr || t_ms >= lim.max_ms * (1 - kSlack)) return std::nullopt;
  const double longer = std::min(lim.max_ms, t_ms * kRangeStep);
  if (ceiling_ms && longer >= *ceiling_ms * (1 - kSlack)) return std::nullopt;
  return longer;
}

}  // namespace gonio::daemon
