// The q-quantile of a sample (nearest rank, q in [0, 1]); 0 for an empty sample. Used for the
// render's noise and ΔE00 statistics.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace gonio::twin {

inline double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const auto n = static_cast<double>(v.size());
  const auto k = static_cast<std::size_t>(std::min(n - 1, std::floor(q * n)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace gonio::twin
