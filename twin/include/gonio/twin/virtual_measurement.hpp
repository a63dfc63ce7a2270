// Virtual measurement of a whole BSDF: the twin's predicted β on an angular grid, turned
// into a tabulated BSDF (f = β/π per node) — what the instrument would deliver to a
// renderer. Used by `gonio-twin render` (right sphere) and `convert`.
#pragma once

#include <memory>

#include "gonio/twin/tabulated.hpp"
#include "gonio/twin/twin.hpp"

namespace gonio::twin {

// An isotropic, bilateral measurement grid: θi, θo in [0, 90), φo relative to the plane of
// incidence in [0, 180] (180 = forward, the specular side).
AngularGrid measurement_grid(double theta_step_deg, double phi_step_deg,
                             double max_theta_deg = 85);

// Geometry of a grid node in the docs/architecture.md §2 frame (wi at φi = 0).
Geometry node_geometry(double theta_i, double theta_o, double phi_o_relative);

// Predicts every node (reflection only) and tabulates f = β/π on the twin's wavelengths.
std::shared_ptr<TabulatedBsdf> measure_tabulated(const Twin& twin, const AngularGrid& grid,
                                                 const EstimatorOptions& options,
                                                 unsigned threads = 0);

}  // namespace gonio::twin
