// Divergence tests between measured and predicted spectra (see divergence.hpp).
#include "gonio/daemon/divergence.hpp"

#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio::daemon {
namespace {
constexpr double kMaxZ = 1e6;
}  // namespace

PointDivergence evaluate_point(const Spectrum& m, const Spectrum& p, double tolerance,
                               const twin::Colorimeter* colorimeter, const DivergenceSettings& s) {
  if (m.size() != p.size() || !(m.wavelengths == p.wavelengths))
    throw Error(Errc::internal, fmt::format("divergence: measured ({} channels) and predicted ({} "
                                            "channels) are on different grids",
                                            m.size(), p.size()));
  PointDivergence d;
  for (std::size_t c = 0; c < m.size(); ++c) {
    const double um = m.std_uncertainty[c], up = p.std_uncertainty[c];
    const double ut = tolerance * p.values[c];
    const double denom = std::sqrt(um * um + up * up + ut * ut);
    const double diff = m.values[c] - p.values[c];
    // Both exact and equal: agreement; exact and different: as unlikely as it gets (kept
    // finite, JSON has no infinity).
    const double z = denom > 0 ? std::min(std::abs(diff) / denom, kMaxZ) : (diff == 0 ? 0.0 : kMaxZ);
    if (z > d.z_max || c == 0) {
      d.z_max = z;
      d.worst_channel = c;
    }
  }
  if (colorimeter) {
    const auto lab_m = colorimeter->lab(m.values);
    const auto lab_p = colorimeter->lab(p.values);
    d.delta_e00 = twin::delta_e2000(lab_m, lab_p);
  }
  d.diverged = d.z_max > s.z_threshold || (d.delta_e00 && *d.delta_e00 > s.delta_e_threshold);
  return d;
}

std::shared_ptr<const twin::Colorimeter> colorimeter_for(const WavelengthGrid& grid) {
  try {
    return std::make_shared<const twin::Colorimeter>(grid);
  } catch (const Error&) {
    return nullptr;  // no overlap with the visible tables, or colord-data missing
  }
}

bool SustainedWindow::push(bool diverged) {
  window_.push_back(diverged);
  count_ += diverged ? 1 : 0;
  while (static_cast<int>(window_.size()) > n_) {
    count_ -= window_.front() ? 1 : 0;
    window_.pop_front();
  }
  return count_ >= m_;
}

std::optional<double> reference_drift(const std::vector<double>& baseline,
                                      const std::vector<double>& current) {
  if (baseline.empty() || baseline.size() != current.size()) return std::nullopt;
  const double b = std::accumulate(baseline.begin(), baseline.end(), 0.0);
  const double c = std::accumulate(current.begin(), current.end(), 0.0);
  if (!(b > 0)) return std::nullopt;
  return std::abs(c / b - 1.0);
}

}  // namespace gonio::daemon
