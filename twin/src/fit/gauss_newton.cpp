// Bounded Gauss–Newton (see gauss_newton.hpp).
#include "gonio/twin/gauss_newton.hpp"

#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Core>

namespace gonio::twin {
namespace {

// Where θ + t·step lands, clamped to the box; `hits` says which bound each parameter met.
void clamped_step(const GaussNewtonProblem& p, const std::vector<double>& theta, const Eigen::VectorXd& step,
                  double t, std::vector<double>& next, std::vector<int>& hits) {
  const bool bounded = !p.lo.empty();
  for (std::size_t i = 0; i < theta.size(); ++i) {
    next[i] = theta[i] + t * step[static_cast<Eigen::Index>(i)];
    hits[i] = 0;
    if (!bounded) continue;
    if (next[i] < p.lo[i]) {
      hits[i] = -1;
      next[i] = p.lo[i];
    } else if (next[i] > p.hi[i]) {
      hits[i] = 1;
      next[i] = p.hi[i];
    }
  }
}

}  // namespace

GaussNewtonResult bounded_gauss_newton(const GaussNewtonProblem& p) {
  const auto n = p.parameters;
  const auto N = static_cast<Eigen::Index>(n);
  GaussNewtonResult r;
  r.at_bound.assign(n, 0);
  std::vector<double> theta = p.start.empty() ? std::vector<double>(n, 0.0) : p.start;
  double chi2 = p.objective(theta);
  for (int iter = 0; iter < p.max_iterations; ++iter) {
    std::vector<double> m, b;
    p.normal_equations(theta, m, b);
    Eigen::MatrixXd M = Eigen::Map<const Eigen::MatrixXd>(m.data(), N, N);
    Eigen::VectorXd rhs = Eigen::Map<const Eigen::VectorXd>(b.data(), N);
    // A parameter held at its bound leaves the system (identity row and column, no step).
    for (std::size_t i = 0; i < n; ++i)
      if (r.at_bound[i] != 0) {
        const auto I = static_cast<Eigen::Index>(i);
        M.row(I).setZero();
        M.col(I).setZero();
        M(I, I) = 1;
      }
    const Eigen::VectorXd raw_rhs = rhs;
    for (std::size_t i = 0; i < n; ++i)
      if (r.at_bound[i] != 0) rhs[static_cast<Eigen::Index>(i)] = 0;
    const Eigen::LLT<Eigen::MatrixXd> llt(M);
    if (llt.info() != Eigen::Success || !(M.diagonal().minCoeff() > 1e-300)) break;
    const Eigen::MatrixXd inverse = llt.solve(Eigen::MatrixXd::Identity(N, N));
    r.inverse.assign(inverse.data(), inverse.data() + inverse.size());
    r.solved = true;
    const Eigen::VectorXd step = inverse * rhs;
    const double size = n ? step.cwiseAbs().maxCoeff() : 0.0;
    double t = 1;
    std::vector<double> next(n);
    std::vector<int> hits(n, 0);
    bool moved = false;
    for (int h = 0; h < p.max_halvings; ++h, t /= 2) {
      clamped_step(p, theta, step, t, next, hits);
      if (const double c = p.objective(next); c <= chi2 + 1e-12 * std::abs(chi2)) {
        theta = next;
        chi2 = c;
        moved = true;
        for (std::size_t i = 0; i < n; ++i)
          if (hits[i] != 0) r.at_bound[i] = hits[i];
        break;
      }
    }
    if (moved && t * size >= 1e-9 * (1 + size)) continue;
    // Converged on the free set: release a held parameter whose descent points back inside.
    bool released = false;
    for (std::size_t i = 0; i < n; ++i)
      if (r.at_bound[i] != 0 && raw_rhs[static_cast<Eigen::Index>(i)] * r.at_bound[i] < 0) {
        r.at_bound[i] = 0;
        released = true;
      }
    if (!released) break;
  }
  if (!r.solved) return r;
  r.theta = std::move(theta);
  r.chi2 = chi2;
  return r;
}

}  // namespace gonio::twin
