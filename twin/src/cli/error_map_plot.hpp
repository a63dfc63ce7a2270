// Rows, summary and plot of `gonio-twin error-map`.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "gonio/proto/geometry.hpp"

namespace gonio::twin::cli {

struct ErrorMapRow {
  Geometry geometry;
  double true_beta = 0, virtual_beta = 0, std_error = 0;  // channel means
};

struct ErrorMapSummary {
  std::size_t compared = 0;
  double max_relative_error = 0;
  Geometry max_at;
  double mean_abs_relative_error = 0;
  std::map<double, double> peak_error;  // by θi
  double grazing_mean_relative_error = 0;
};

ErrorMapSummary summarise(const std::vector<ErrorMapRow>& rows, double floor);

// In-plane curves per incidence angle, true (lines) vs virtual (markers, ±σ), like the
// founding paper's figures 4–7. Throws Error(io_error) when the file cannot be written.
void plot_error_map(const std::string& path, const std::vector<ErrorMapRow>& rows,
                    const std::string& title, bool log_y);

}  // namespace gonio::twin::cli
