// What the verdict's files share (evidence.cpp accumulates, verdict_fit.cpp fits, verdict.cpp
// decides and words): the accumulated matrices are plain vectors, so that verdict.hpp stays
// free of Eigen, worked on through maps.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace gonio::daemon::evidence {

inline constexpr auto npos = std::string::npos;

using Matrix = Eigen::Map<Eigen::MatrixXd>;
using ConstMatrix = Eigen::Map<const Eigen::MatrixXd>;
using ConstVector = Eigen::Map<const Eigen::VectorXd>;

inline Matrix view(std::vector<double>& v, std::size_t n) {
  return Matrix(v.data(), static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
}
inline ConstMatrix view(const std::vector<double>& v, std::size_t n) {
  return ConstMatrix(v.data(), static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
}
inline ConstVector view(const std::vector<double>& v) {
  return ConstVector(v.data(), static_cast<Eigen::Index>(v.size()));
}
// bᵀ M b
inline double form(const std::vector<double>& m, std::size_t n, const std::vector<double>& b) {
  return view(b).dot(view(m, n) * view(b));
}

// P(χ² ≥ x) for `dof` degrees of freedom.
double chi2_p_value(double x, double dof);

}  // namespace gonio::daemon::evidence
