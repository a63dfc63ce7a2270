// The verdict's fits: each hypothesis a bounded Gauss–Newton fit of the accumulated normal
// equations (gonio/twin/gauss_newton.hpp), and what a fit says about bands, regions, scatter
// and a sample parameter's effect (see verdict.hpp).
#include "gonio/daemon/instrument/verdict.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Core>
#include <boost/math/special_functions/gamma.hpp>

#include "gonio/daemon/instrument/divergence.hpp"
#include "gonio/twin/gauss_newton.hpp"
#include "instrument/evidence_matrix.hpp"

namespace gonio::daemon {
using evidence::form;
using evidence::npos;
using evidence::view;

// P(χ² ≥ x) for `dof` degrees of freedom (the upper regularised incomplete gamma function).
double evidence::chi2_p_value(double x, double dof) {
  if (!(x > 0)) return 1.0;
  if (!std::isfinite(x)) return 0.0;
  return boost::math::gamma_q(dof / 2, x / 2);
}

// The model in extended columns: f = Σ c1_j θ_j + ½ c2_j θ_j² + c_jk θ_j θ_k; the residual
// left is r − f, whose coefficients over the extended columns this returns.
std::vector<double> ScanEvidence::coefficients(const std::vector<std::size_t>& columns,
                                               const std::vector<double>& th) const {
  std::vector<double> beta(E_, 0.0);
  beta[residual_] = 1;
  const auto position = [&](std::size_t column) {
    const auto it = std::find(columns.begin(), columns.end(), column);
    return it == columns.end() ? npos : static_cast<std::size_t>(it - columns.begin());
  };
  for (std::size_t i = 0; i < columns.size(); ++i) {
    const auto j = columns[i];
    beta[j] -= th[i];
    if (const auto k = curvature_of_[j]; k != npos) beta[k] -= 0.5 * th[i] * th[i];
    if (const auto p = partner_[j] == npos ? npos : position(partner_[j]); p != npos) beta[cross_of_[j]] -= th[i] * th[p];
  }
  return beta;
}

// One hypothesis: `columns` fitted, those not in `free` held to their priors. χ² is the
// quadratic form of the residual's coefficients in G plus the priors' penalty; its normal
// equations are M = Γᵀ G Γ + priors, with Γ the derivatives of the model f over the extended
// columns (∂f/∂θ_i), and the bounded Gauss–Newton of gonio/twin/gauss_newton.hpp solves them.
ScanEvidence::Fit ScanEvidence::solve(const std::vector<std::size_t>& columns,
                                      const std::vector<std::size_t>& free) const {
  Fit f;
  f.index = columns;
  f.free = free;
  const auto n = columns.size();
  const auto N = static_cast<Eigen::Index>(n);
  const auto E = static_cast<Eigen::Index>(E_);
  const auto G = view(G_, E_);
  Eigen::VectorXd prior = Eigen::VectorXd::Zero(N);  // 1/u² of each column held to its prior, else 0
  for (std::size_t i = 0; i < n; ++i) {
    const bool is_free = std::find(free.begin(), free.end(), columns[i]) != free.end();
    const double pu = names_[columns[i]].prior_u;
    if (!is_free && pu > 0) prior[static_cast<Eigen::Index>(i)] = 1.0 / (pu * pu);
  }
  // The position in the fit of each column's interaction partner (npos: none, or not fitted).
  std::vector<std::size_t> partner(n, npos);
  for (std::size_t i = 0; i < n; ++i)
    if (const auto k = partner_[columns[i]]; k != npos)
      if (const auto it = std::find(columns.begin(), columns.end(), k); it != columns.end())
        partner[i] = static_cast<std::size_t>(it - columns.begin());
  twin::GaussNewtonProblem problem;
  problem.parameters = n;
  problem.objective = [&](const std::vector<double>& th) {
    double chi2 = form(G_, E_, coefficients(columns, th));
    for (std::size_t i = 0; i < n; ++i) chi2 += prior[static_cast<Eigen::Index>(i)] * th[i] * th[i];
    return chi2;
  };
  problem.normal_equations = [&](const std::vector<double>& theta, std::vector<double>& M_out,
                                 std::vector<double>& rhs_out) {
    const auto beta_values = coefficients(columns, theta);
    const auto beta = view(beta_values);
    Eigen::MatrixXd gamma = Eigen::MatrixXd::Zero(E, N);
    for (std::size_t i = 0; i < n; ++i) {
      const auto I = static_cast<Eigen::Index>(i);
      gamma(static_cast<Eigen::Index>(columns[i]), I) = 1;
      if (const auto k = curvature_of_[columns[i]]; k != npos) gamma(static_cast<Eigen::Index>(k), I) = theta[i];
    }
    for (std::size_t i = 0; i < n; ++i)
      if (partner[i] != npos) {
        const auto x = static_cast<Eigen::Index>(cross_of_[columns[i]]);
        gamma(x, static_cast<Eigen::Index>(i)) = theta[partner[i]];
        gamma(x, static_cast<Eigen::Index>(partner[i])) = theta[i];
      }
    const Eigen::MatrixXd Gg = G * gamma;
    Eigen::MatrixXd M = gamma.transpose() * Gg;
    M.diagonal() += prior;
    Eigen::VectorXd rhs = Gg.transpose() * beta;
    for (std::size_t i = 0; i < n; ++i) rhs[static_cast<Eigen::Index>(i)] -= prior[static_cast<Eigen::Index>(i)] * theta[i];
    M_out.assign(M.data(), M.data() + M.size());
    rhs_out.assign(rhs.data(), rhs.data() + rhs.size());
  };
  // A rectangular (or triangular) input held to its data sheet cannot lie beyond ±its limit:
  // a hard bound beside the normal penalty.
  constexpr double inf = std::numeric_limits<double>::infinity();
  problem.lo.assign(n, -inf);
  problem.hi.assign(n, inf);
  for (std::size_t i = 0; i < n; ++i)
    if (prior[static_cast<Eigen::Index>(i)] > 0 && names_[columns[i]].bounded && names_[columns[i]].limit > 0) {
      problem.lo[i] = -names_[columns[i]].limit;
      problem.hi[i] = names_[columns[i]].limit;
    }
  auto solved = twin::bounded_gauss_newton(problem);
  if (!solved.solved) {
    f.chi2 = std::numeric_limits<double>::infinity();
    return f;
  }
  f.theta = std::move(solved.theta);
  f.u.assign(n, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    f.u[i] = solved.at_bound[i] != 0 ? 0.0 : std::sqrt(std::max(0.0, solved.inverse[i * n + i]));
  f.chi2 = solved.chi2;
  return f;
}

bool ScanEvidence::is_candidate(std::size_t j) const {
  return names_[j].kind == "sample" || names_[j].unit == "deg" || names_[j].name == "gain";
}

// The candidates that need points to be told apart: a band is a combination of nodes already
// counted, or of the catalogue's β.
std::size_t ScanEvidence::candidates() const noexcept {
  std::size_t n = 0;
  for (std::size_t j = 0; j < names_.size(); ++j) n += is_candidate(j) && !names_[j].band() ? 1 : 0;
  return n;
}

std::vector<ScanEvidence::Fitted> ScanEvidence::fit_candidates(const std::vector<std::size_t>& instrument,
                                                               const std::vector<std::size_t>& sample) const {
  std::vector<Fitted> cands;
  // The instrument's candidate causes are its arms and its white; the apertures stay
  // nuisance inputs held to their data sheet (a few percent of an aperture moves β little
  // and alike everywhere, so a free aperture would soak up whatever else is left).
  for (auto j : instrument)
    if (is_candidate(j)) cands.push_back({j, solve(instrument, {j})});
  for (auto k : sample) {
    auto cols = instrument;
    cols.push_back(k);
    cands.push_back({k, solve(cols, {k})});
  }
  // Extrapolations of the linear model are no evidence (see max_change).
  std::erase_if(cands, [&](const Fitted& c) {
    const auto pos = static_cast<std::size_t>(std::find(c.fit.index.begin(), c.fit.index.end(), c.column) -
                                              c.fit.index.begin());
    return pos >= c.fit.theta.size() || !(std::abs(c.fit.theta[pos]) <= names_[c.column].max_change);
  });
  std::sort(cands.begin(), cands.end(), [](const Fitted& a, const Fitted& b) { return a.fit.chi2 < b.fit.chi2; });
  return cands;
}

// The cause a candidate names: its free parameter's value and u (scaled by √(χ²/dof) when
// the fit is worse than its uncertainties say).
VerdictCause ScanEvidence::cause_of(const Fitted& c) const {
  const auto& col = names_[c.column];
  const auto pos =
      static_cast<std::size_t>(std::find(c.fit.index.begin(), c.fit.index.end(), c.column) - c.fit.index.begin());
  const double scale = std::sqrt(std::max(1.0, c.fit.chi2 / dof(1)));
  VerdictCause cause{col.kind, col.name, col.nominal + c.fit.theta[pos], c.fit.u[pos] * scale, col.nominal, {}};
  if (col.band()) cause.band_nm = std::array<double, 2>{col.band_lo, col.band_hi};
  return cause;
}

// The mean relative difference of one group of channels (a wavelength band, a region) left by
// `fit` (its instrument inputs removed), with its uncertainty: the points' own, scaled by
// `scale`, and the instrument's systematic inputs' (posterior). Folded into `out`, the worst.
ScanEvidence::MeanResult ScanEvidence::mean_decision(const Fit& fit, const Moments& m, double scale,
                                                     MeanResult out) const {
  const auto theta_of = [&](std::size_t column) {
    const auto it = std::find(fit.index.begin(), fit.index.end(), column);
    return it == fit.index.end() ? 0.0 : fit.theta[static_cast<std::size_t>(it - fit.index.begin())];
  };
  // Σ p·r'/v and Σ p·∂r'/∂θ_i /v of the residual r' with the fitted instrument inputs'
  // effect removed (r' = r − s θ − ½ c₂ θ² − c×θ θ_partner), from the group's moments.
  const double s0 = m.pp;
  double s1 = m.pr;
  std::vector<double> sj(fit.index.size(), 0.0);
  for (std::size_t i = 0; i < fit.index.size(); ++i) {
    const auto j = fit.index[i];
    if (names_[j].kind == "sample") continue;
    const double th = fit.theta[i];
    const double other = cross_of_[j] != npos ? theta_of(partner_[j]) : 0.0;
    s1 -= m.ps[j] * th + 0.5 * m.pc2[j] * th * th + m.px[j] * th * other;
    sj[i] = m.ps[j] + m.pc2[j] * th + m.px[j] * other;
  }
  if (!(s0 > 0)) return out;
  const double mean = s1 / s0;
  double var = scale * scale / s0;
  for (std::size_t i = 0; i < fit.index.size(); ++i) {
    if (names_[fit.index[i]].kind == "sample") continue;
    var += std::pow(fit.u[i] * sj[i] / s0, 2);
  }
  const double u = std::sqrt(var);
  const auto bd = decide(mean, u, tolerance_, k_);
  if ((static_cast<int>(bd) > static_cast<int>(out.decision) || std::abs(mean) > std::abs(out.worst_rel)) &&
      static_cast<int>(bd) >= static_cast<int>(out.decision)) {
    out.worst_rel = mean;
    out.worst_u = u;
  }
  out.decision = worse(out.decision, bd);
  return out;
}

ScanEvidence::MeanResult ScanEvidence::band_decision(const Fit& fit) const {
  const double scale = std::sqrt(std::max(1.0, fit.chi2 / dof(fit.free.size())));
  MeanResult out;
  for (const auto& band : bands_) out = mean_decision(fit, band, scale, out);
  return out;
}

// Every region's χ² left by `fit` and its mean relative difference, judged like a band's;
// the worst (by how far their χ² stands above its channels) first.
std::vector<MisfitRegion> ScanEvidence::regions_of(const Fit& fit) const {
  const auto beta = coefficients(fit.index, fit.theta);
  const double scale = std::sqrt(std::max(1.0, fit.chi2 / dof(fit.free.size())));
  std::vector<std::pair<double, MisfitRegion>> ranked;
  for (const auto& r : regions_) {
    if (r.channels == 0) continue;
    const double chi2 = form(r.G, E_, beta);
    const double n = static_cast<double>(r.channels);
    const auto mean = mean_decision(fit, r.moments, scale, MeanResult{});
    MisfitRegion m{r.theta_i, r.bin * kRegionDeg, (r.bin + 1) * kRegionDeg, r.points, chi2 / n,
                   mean.worst_rel, mean.worst_u, mean.decision};
    ranked.emplace_back((chi2 - n) / std::sqrt(2 * n), m);
  }
  std::sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<MisfitRegion> out;
  for (auto& [excess, m] : ranked) out.push_back(m);
  return out;
}

// The extra variance of random arm scatter, by moments of the residuals projected on the
// arms' sensitivity: E[z²] = 1 + σ²q per point, so with weights w (add_scatter_terms)
// σ² = Σ w (z² − 1) / Σ w q, unbiased for any w, and u(σ²)² = 2 Σ w² (1 + σ²q)² / (Σ w q)².
ScanEvidence::Scatter ScanEvidence::scatter_of(const Fit& fit) const {
  Scatter s;
  if (!(sum_wq_ > 0) || points_ < 3) return s;
  const auto beta = coefficients(fit.index, fit.theta);
  s.extra_var = (form(Zw_, E_, beta) - sum_w_) / sum_wq_;
  const double v = s.extra_var;
  s.u_extra_var = std::sqrt(2 * std::max(0.0, sum_w2_ + 2 * v * sum_w2q_ + v * v * sum_w2q2_)) / sum_wq_;
  const double zz = form(Zs_, E_, beta);
  s.rho = zz > 0 ? form(Lag_, E_, beta) / zz : 0.0;  // bᵀLb = bᵀ(L + Lᵀ)b/2
  s.named = s.u_extra_var > 0 && s.extra_var > kScatterZ * s.u_extra_var && s.rho < kScatterRho;
  return s;
}

// The χ² the Taylor remainder of a candidate's fitted change may leave: kTruncation² times the
// χ² of its own effect (Σ (ε·effect)²/var, a quadratic form in G like every χ² here).
double ScanEvidence::truncation_chi2(const Fitted& c) const {
  const auto& col = names_[c.column];
  if (col.band() || col.name == "gain") return 0.0;
  const auto pos =
      static_cast<std::size_t>(std::find(c.fit.index.begin(), c.fit.index.end(), c.column) - c.fit.index.begin());
  auto effect = coefficients({c.column}, {c.fit.theta[pos]});
  effect[residual_] = 0;
  return kTruncation * kTruncation * form(G_, E_, effect);
}

// The effect of a sample parameter's fitted change on β, judged point by point. At a channel
// with sensitivity s the rule (decide) compares |s·δ| ± k·|s|·u with tolerance·|β|, that is
// |δ| ± k·u with tolerance·|β|/|s|: the point is out of tolerance where some channel is,
// and agrees where every channel does, exactly as the rule judges δ against the smallest of
// those margins.
Decision ScanEvidence::effect_decision(const Fitted& c, std::size_t& out_points) const {
  const auto cause = cause_of(c);
  const double delta = cause.value - cause.nominal;
  const auto slot = static_cast<std::size_t>(
      std::find(sample_columns_.begin(), sample_columns_.end(), c.column) - sample_columns_.begin());
  Decision d = Decision::agrees;
  out_points = 0;
  for (std::size_t i = 0; i < points_; ++i) {
    const Decision pd = decide(delta, cause.u, margins_[i * sample_columns_.size() + slot], k_);
    if (pd == Decision::out_of_tolerance) ++out_points;
    d = worse(d, pd);
  }
  return d;
}

}  // namespace gonio::daemon
