#include "gonio/twin/virtual_measurement.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "gonio/proto/error.hpp"

namespace gonio::twin {

AngularGrid measurement_grid(double theta_step_deg, double phi_step_deg, double max_theta_deg) {
  if (!(theta_step_deg >= 0.1 && theta_step_deg <= 45))
    throw Error::out_of_range("theta_step", theta_step_deg, 0.1, 45, "°");
  if (!(phi_step_deg >= 1 && phi_step_deg <= 90))
    throw Error::out_of_range("phi_step", phi_step_deg, 1, 90, "°");
  if (!(max_theta_deg >= 1 && max_theta_deg <= 89))
    throw Error::out_of_range("max_theta", max_theta_deg, 1, 89, "°");
  AngularGrid g;
  g.bilateral = true;
  for (double t = 0; t <= max_theta_deg + 1e-9; t += theta_step_deg) {
    g.theta_i.push_back(std::round(t * 1e6) / 1e6);
    g.theta_o.push_back(std::round(t * 1e6) / 1e6);
  }
  for (double p = 0; p <= 180 + 1e-9; p += phi_step_deg) g.phi_o.push_back(std::round(p * 1e6) / 1e6);
  if (g.phi_o.back() < 180) g.phi_o.push_back(180);
  return g;
}

Geometry node_geometry(double theta_i, double theta_o, double phi_o_relative) {
  // wi = (−sin θi, 0, cos θi) sits at azimuth 180°; the table's φo is relative to it.
  double phi_r = 180 + phi_o_relative;
  while (phi_r > 180) phi_r -= 360;
  return Geometry{theta_i, 0, theta_o, phi_r};
}

std::shared_ptr<TabulatedBsdf> measure_tabulated(const Twin& twin, const AngularGrid& grid,
                                                 const EstimatorOptions& options,
                                                 unsigned threads) {
  if (!grid.phi_i.empty()) throw Error::invalid("grid.phi_i", "must be empty (isotropic)");
  std::vector<Geometry> nodes;
  nodes.reserve(grid.theta_i.size() * grid.theta_o.size() * grid.phi_o.size());
  // Layout of BsdfTable: channel fastest, then θi (p0), φi (p1, one node), θo (p2), φo (p3).
  for (double po : grid.phi_o)
    for (double to : grid.theta_o)
      for (double ti : grid.theta_i) nodes.push_back(node_geometry(ti, to, po));
  const auto pred = twin.predict_many(nodes, options, threads);
  const std::size_t C = twin.wavelengths().size();
  std::vector<double> values(nodes.size() * C);
  for (std::size_t k = 0; k < nodes.size(); ++k)
    for (std::size_t c = 0; c < C; ++c)
      values[k * C + c] = std::max(0.0, pred[k].beta[c]) * kInvPi;
  return std::make_shared<TabulatedBsdf>(twin.wavelengths(), grid, twin.wavelengths().values(),
                                         std::move(values), std::vector<double>{},
                                         "virtually measured " + twin.sample().spec());
}

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
