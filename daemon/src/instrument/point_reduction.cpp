// β and its uncertainty from the readings of one point, and reference drift (see
// point_reduction.hpp).
#include "gonio/daemon/instrument/point_reduction.hpp"

#include <cmath>

#include <fmt/format.h>

#include "gonio/daemon/instrument/divergence.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {

std::vector<double> resample(const WavelengthGrid& from, const std::vector<double>& values,
                             const WavelengthGrid& to) {
  if (from == to) return values;
  return interpolate_linear(from.values(), values, to.values());
}

ReducedPoint reduce_point(const PointSignals& in, double beta_ref, const WavelengthGrid& target) {
  const Spectrum& S = in.sample;
  const Spectrum& D = in.dark;
  const Spectrum& R = in.reference;
  const Spectrum& DR = in.reference_dark;
  const std::size_t n = S.size();
  if (D.size() != n || R.size() != n || DR.size() != n)
    throw Error(Errc::protocol_error, "readings of one point have different channel counts");
  std::vector<double> beta(n), u(n), net_ref(n);
  for (std::size_t c = 0; c < n; ++c) {
    const double ns = S.values[c] - D.values[c];
    const double nr = R.values[c] - DR.values[c];
    net_ref[c] = nr;
    if (!(nr > 0))
      throw Error(Errc::device_alarm,
                  fmt::format("the reference signal is not above dark at {:g} nm (is the lamp "
                              "on?)",
                              S.wavelengths[c]),
                  "reference");
    beta[c] = beta_ref * ns / nr;
    const auto sq = [](double x) { return x * x; };
    const auto unc = [&](const Spectrum& s) {
      return s.std_uncertainty.size() == n ? s.std_uncertainty[c] : 0.0;
    };
    const double us2 = sq(unc(S)) + sq(unc(D));
    const double ur2 = sq(unc(R)) + sq(unc(DR));
    u[c] = std::sqrt(us2 * sq(beta_ref / nr) + ur2 * sq(beta[c] / nr));
  }
  ReducedPoint out;
  out.beta = Spectrum(target, resample(S.wavelengths, beta, target),
                      resample(S.wavelengths, u, target));
  out.net_reference = std::move(net_ref);
  return out;
}

std::optional<double> ReferenceDriftMonitor::observe(const std::vector<double>& net_reference) {
  if (baseline_.empty()) {
    baseline_ = net_reference;
    return std::nullopt;
  }
  const auto drift = reference_drift(baseline_, net_reference);
  if (drift && *drift > limit_) return drift;
  return std::nullopt;
}

}  // namespace gonio::daemon
