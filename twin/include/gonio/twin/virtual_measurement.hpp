// Virtual measurement of a whole BSDF: the twin's predicted β on a specular grid, turned
// into a tabulated BSDF (f = β/π per node) — what the instrument would deliver to a
// renderer. Used by `gonio-twin render` (the measured sphere) and `convert --virtual`.
//
// The grid is specular (θi, angle from the specular direction, azimuth about it): it keeps a
// glossy lobe at radial 0 for every θi, so interpolation does not invent energy, where a
// spherical grid (θi, θo, φo in fixed steps) spreads the peak over whole cells
// (twin/rendering.md: a conductor with α = 0.05 on 2.5°/15° reflects 10× too much at
// θo = 85°).
#pragma once

#include <vector>

#include "gonio/twin/tabulated.hpp"
#include "gonio/twin/twin.hpp"

namespace gonio::twin {

// A specular grid that does not depend on the BSDF: θi every `theta_step_deg` from 0 to 85°,
// radial angles from 0 in steps that start at `radial_step_deg` and grow by 10 % per node up
// to 180° (fine where any measured lobe peaks — the instrument's apertures widen the
// narrowest lobe to ≈ 2° — coarse in the tails), azimuths 0…180° every `phi_step_deg`.
// Ranges: θ step 0.5–45°, radial step 0.05–10°, φ step 1–90° (Error naming the field).
SpecularGrid specular_measurement_grid(double theta_step_deg, double radial_step_deg,
                                       double phi_step_deg);

// The nominal instrument geometries of a specular grid's nodes, each distinct one once
// (radial 0 at every azimuth, nodes pulled onto the horizon), and for every node (table
// order) the index of its geometry. Receivers stay 1° above the sample plane, the
// instrument's limit.
struct SpecularGeometries {
  std::vector<Geometry> geometries;
  std::vector<std::size_t> node_geometry;
};
SpecularGeometries specular_geometries(const SpecularGrid& grid);

// Predicts the distinct geometries of the grid and returns the bilateral specular BRDF
// table f = β/π on the twin's wavelengths.
BsdfTable measure_specular(const Twin& twin, const SpecularGrid& grid,
                           const EstimatorOptions& options, unsigned threads = 0);

}  // namespace gonio::twin
