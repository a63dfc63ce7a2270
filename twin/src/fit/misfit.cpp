// Where a fitted model misses the data: the residuals grouped by incidence angle and by the
// part of the receiving range a metrologist would name (the specular peak, grazing
// reception, backscatter, the diffuse rest), ranked by their share of χ².
#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include <fmt/format.h>

#include "gonio/twin/detail/fit/solver.hpp"

namespace gonio::twin::fit {
namespace {

// Angle between the receiving direction and the mirror direction of the incident one.
double off_specular_deg(const Geometry& g) {
  const auto a = g.incident_direction();
  const auto b = g.receiving_direction();
  const double c = -a[0] * b[0] - a[1] * b[1] + a[2] * b[2];
  return std::acos(std::clamp(c, -1.0, 1.0)) * kRadToDeg;
}

std::string region_of(const Geometry& g) {
  if (off_specular_deg(g) <= 10) return "specular";
  if (!g.in_measurement_plane()) return "out-of-plane";
  if (std::abs(g.theta_r) > 70) return "grazing";
  // In the plane of measurement the receiver is on the source's side for θr < 0.
  if (g.theta_r < 0) return "backscatter";
  return "diffuse";
}

std::string describe(const std::string& region) {
  if (region == "specular") return "within 10° of the specular direction";
  if (region == "grazing") return "θr beyond 70°";
  if (region == "backscatter") return "on the source's side";
  if (region == "out-of-plane") return "out of the plane";
  return "the diffuse range";
}

}  // namespace

std::vector<MisfitRegion> misfit_regions(const MeasuredData& data, const Optimum& at,
                                         std::size_t limit) {
  const std::size_t ch = data.wavelengths.size();
  struct Acc {
    std::size_t points = 0, residuals = 0;
    double chi2 = 0, rel2 = 0;
    std::size_t rel_n = 0;
  };
  std::map<std::pair<double, std::string>, Acc> acc;
  double total = 0;
  for (std::size_t k = 0; k < data.points.size(); ++k) {
    const auto& p = data.points[k];
    auto& a = acc[{std::round(p.geometry.theta_i * 10) / 10, region_of(p.geometry)}];
    ++a.points;
    for (std::size_t c = 0; c < ch; ++c) {
      const std::size_t i = k * ch + c;
      if (i >= at.z.size()) break;
      const double z2 = at.z[i] * at.z[i];
      a.chi2 += z2;
      total += z2;
      ++a.residuals;
      if (p.beta[c] != 0) {
        const double rel = (at.beta[i] - p.beta[c]) / p.beta[c];
        a.rel2 += rel * rel;
        ++a.rel_n;
      }
    }
  }
  std::vector<MisfitRegion> out;
  for (const auto& [key, a] : acc) {
    MisfitRegion r;
    r.theta_i = key.first;
    r.region = key.second;
    r.points = a.points;
    r.chi2_share = total > 0 ? a.chi2 / total : 0;
    r.chi2_per_residual = a.residuals > 0 ? a.chi2 / static_cast<double>(a.residuals) : 0;
    r.rms_relative = a.rel_n > 0 ? std::sqrt(a.rel2 / static_cast<double>(a.rel_n)) : 0;
    out.push_back(r);
  }
  std::stable_sort(out.begin(), out.end(), [](const auto& x, const auto& y) {
    return x.chi2_share > y.chi2_share;
  });
  if (out.size() > limit) out.resize(limit);
  return out;
}

std::string misfit_warning(const FitResult& r) {
  std::string worst;
  for (std::size_t k = 0; k < r.misfit.size() && k < 3; ++k) {
    const auto& m = r.misfit[k];
    worst += fmt::format("{}θi = {:g}° {} ({} points): {:.0f} % of χ², RMS residual {:.1f} %",
                         k == 0 ? "" : "; ", m.theta_i, describe(m.region), m.points,
                         100 * m.chi2_share, 100 * m.rms_relative);
  }
  return fmt::format("the model does not describe the data: χ²/dof = {:.4g} (a good fit is "
                     "near 1); worst: {}",
                     r.chi2_per_dof, worst.empty() ? "—" : worst);
}

}  // namespace gonio::twin::fit
