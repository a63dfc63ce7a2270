#include "gonio/twin/virtual_measurement.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "gonio/proto/error.hpp"

namespace gonio::twin {

SpecularGrid specular_measurement_grid(double theta_step_deg, double radial_step_deg,
                                       double phi_step_deg) {
  if (!(theta_step_deg >= 0.5 && theta_step_deg <= 45))
    throw Error::out_of_range("theta_step", theta_step_deg, 0.5, 45, "°");
  if (!(radial_step_deg >= 0.05 && radial_step_deg <= 10))
    throw Error::out_of_range("radial_step", radial_step_deg, 0.05, 10, "°");
  if (!(phi_step_deg >= 1 && phi_step_deg <= 90))
    throw Error::out_of_range("phi_step", phi_step_deg, 1, 90, "°");
  const auto rounded = [](double v) { return std::round(v * 1e6) / 1e6; };
  SpecularGrid g;
  for (int k = 0;; ++k) {
    const double t = std::min(85.0, k * theta_step_deg);
    g.theta_i.push_back(rounded(t));
    if (t >= 85) break;
  }
  double r = 0, step = radial_step_deg;
  while (r < 180) {
    g.radial.push_back(rounded(r));
    r += step;
    step *= 1.1;
  }
  g.radial.push_back(180);
  for (double a = 0; a < 180 - 1e-9; a += phi_step_deg) g.azimuth.push_back(rounded(a));
  g.azimuth.push_back(180);
  return g;
}

SpecularGeometries specular_geometries(const SpecularGrid& grid) {
  const auto dirs = specular_grid_directions(grid);
  SpecularGeometries out;
  out.node_geometry.resize(dirs.size());
  std::map<std::tuple<long, long, long>, std::size_t> index;
  for (std::size_t k = 0; k < dirs.size(); ++k) {
    const auto& [wi, wo] = dirs[k];
    const double ti = std::acos(std::clamp(wi.z, -1.0, 1.0)) * kRadToDeg;
    const double to = std::min(89.0, std::acos(std::clamp(wo.z, -1.0, 1.0)) * kRadToDeg);
    const double po = (wo.x == 0 && wo.y == 0) ? 0.0 : std::atan2(wo.y, wo.x) * kRadToDeg;
    const auto key = std::make_tuple(std::lround(ti * 1e4), std::lround(to * 1e4),
                                     std::lround(po * 1e4));
    const auto [it, fresh] = index.emplace(key, out.geometries.size());
    if (fresh) out.geometries.push_back(Geometry{ti, 0, to, po});
    out.node_geometry[k] = it->second;
  }
  return out;
}

BsdfTable measure_specular(const Twin& twin, const SpecularGrid& grid,
                           const EstimatorOptions& options, unsigned threads) {
  const auto geo = specular_geometries(grid);
  const auto pred = twin.predict_many(geo.geometries, options, threads);
  const std::size_t C = twin.wavelengths().size();
  std::vector<double> values(geo.node_geometry.size() * C);
  for (std::size_t k = 0; k < geo.node_geometry.size(); ++k)
    for (std::size_t c = 0; c < C; ++c)
      values[k * C + c] = std::max(0.0, pred[geo.node_geometry[k]].beta[c]) * kInvPi;
  return BsdfTable(TableParam::specular, {grid.theta_i, {}, grid.radial, grid.azimuth},
                   twin.wavelengths().values(), std::move(values), {true, false});
}

}  // namespace gonio::twin
