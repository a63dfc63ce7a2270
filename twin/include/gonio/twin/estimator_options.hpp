// How the twin's estimator runs, and the twin's one set of defaults: goniod's [twin] keys and
// gonio-twin's --rel-se, --max-samples and --replicates all start from these.
#pragma once

#include <cstdint>

namespace gonio::twin {

enum class EstimatorKind {
  rqmc,      // Owen-scrambled Sobol, analytic footprint overlap, MIS of aperture and BSDF
  baseline,  // the founding paper's scheme: uniform pupil sampling, (n·v)^4, plain MC
};

// The defaults of rel_se, max_samples and replicates are what a prediction per scan point
// costs in goniod (its runner and gonio-load's figures were measured with them): 0.2 % keeps
// a prediction ahead of the arms, and 16 replicates give its standard error 15 degrees of
// freedom. A command that needs less noise asks for it (--rel-se, --replicates).
struct EstimatorOptions {
  EstimatorKind kind = EstimatorKind::rqmc;
  double rel_se = 2e-3;                   // stop when every channel has s.e. ≤ rel_se·β
  double abs_se = 1e-6;                   // ... or s.e. ≤ abs_se (β units), for dark channels
  std::uint64_t max_samples = 1ull << 20; // budget per geometry, sample + reference paths
  int replicates = 16;                    // R independent randomisations
  // Points per replicate before the first convergence check (a power of two), doubled
  // until the target holds. Fewer let easy geometries stop sooner; the check's reliability
  // rests on the R replicates, not on this.
  std::uint64_t first_points = 64;
  std::uint64_t seed = 1;
  void validate() const;  // twin.cpp
};

}  // namespace gonio::twin
