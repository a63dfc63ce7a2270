// ParameterDesign — sequential Bayesian D-optimal design on the twin's Jacobian.
//
// At the current estimate x the design is linearised: candidate c would add the information
// ΔF_c = J_cᵀ W_c J_c about the parameters (J_c the twin's β per channel against them, W_c the
// inverse variances its reading will have). With F the information of the points measured
// and pending plus a weak prior (Bayesian D-optimality, Chaloner & Verdinelli, Statist. Sci.
// 10 (1995) 273, §2.2), the gain of c is log det(F + ΔF_c) − log det F: the volume by which
// the parameters' uncertainty ellipsoid shrinks. Dividing by the instrument time the point
// costs from where the arms stand gives information per second, the cost-constrained form
// of sequential design (Atkinson, Donev & Tobias, Optimum Experimental Designs, 2007, §10.11
// and ch. 17).
#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/design.hpp"
#include "gonio/twin/twin.hpp"

namespace gonio::twin {

namespace {

// The noise the readings of unmeasured candidates will have, from those measured:
// u² = abs² + (rel·β)², abs the smallest u seen, rel the median of the rest relative to β.
struct NoiseModel {
  double rel = 0.005, abs = 5e-4;
  double u(double beta) const { return std::hypot(abs, rel * beta); }
};

NoiseModel noise_of(const MeasuredData& data) {
  NoiseModel m;
  if (data.points.empty()) return m;
  double lo = 1e300;
  for (const auto& p : data.points)
    for (double u : p.u) lo = std::min(lo, u);
  std::vector<double> rel;
  for (const auto& p : data.points)
    for (std::size_t k = 0; k < p.u.size(); ++k)
      if (p.beta[k] > 0 && p.u[k] > lo) rel.push_back(std::sqrt(p.u[k] * p.u[k] - lo * lo) / p.beta[k]);
  m.abs = lo;
  if (!rel.empty()) {
    std::nth_element(rel.begin(), rel.begin() + static_cast<long>(rel.size() / 2), rel.end());
    m.rel = rel[rel.size() / 2];
  }
  return m;
}

}  // namespace

double ParameterDesignOptions::ModelTrust::relative_u(const Geometry& g) const {
  const double u = near_specular + per_10deg * std::abs(g.aspecular()) / 10;
  return g.theta_r >= grazing_deg ? u * grazing_factor : u;
}

void ParameterDesignOptions::validate() const {
  if (!(target_rel_u > 0 && target_rel_u <= 1))
    throw Error::out_of_range("target_rel_u", target_rel_u, 0, 1);
  timing.validate();
  fit.validate();
  if (jacobian_samples < 256 || jacobian_samples > (1u << 24))
    throw Error::out_of_range("jacobian_samples", static_cast<double>(jacobian_samples), 256, 1 << 24);
  if (max_readings < 1 || max_readings > 100) throw Error::out_of_range("max_readings", max_readings, 1, 100);
  if (jacobian_replicates < 4 || jacobian_replicates > 64)
    throw Error::out_of_range("jacobian_replicates", jacobian_replicates, 4, 64);
  if (!(model_trust.near_specular >= 0 && model_trust.near_specular <= 1))
    throw Error::out_of_range("model_trust.near_specular", model_trust.near_specular, 0, 1);
  if (!(model_trust.per_10deg >= 0 && model_trust.per_10deg <= 1))
    throw Error::out_of_range("model_trust.per_10deg", model_trust.per_10deg, 0, 1);
  if (!(model_trust.grazing_deg >= 0 && model_trust.grazing_deg <= 90))
    throw Error::out_of_range("model_trust.grazing_deg", model_trust.grazing_deg, 0, 90, "°");
  if (!(model_trust.grazing_factor >= 1 && model_trust.grazing_factor <= 100))
    throw Error::out_of_range("model_trust.grazing_factor", model_trust.grazing_factor, 1, 100);
  if (!(max_cell_share > 0 && max_cell_share <= 1)) throw Error::out_of_range("max_cell_share", max_cell_share, 0, 1);
}

ParameterDesign::ParameterDesign(std::string model, std::vector<Geometry> candidates, WavelengthGrid grid,
                                 InstrumentProfile profile, ParameterDesignOptions options)
    : Design(std::move(candidates), options.max_readings),
      model_(std::move(model)),
      grid_(std::move(grid)),
      profile_(std::move(profile)),
      options_(std::move(options)) {
  options_.validate();
  profile_.validate();
  tmpl_ = std::make_unique<ModelTemplate>(model_, grid_);
  for (const auto& p : tmpl_->parameters()) x_.push_back(p.start);
  data_.wavelengths = grid_;
  data_.source = "adaptive scan";
  // Each candidate in the cell of its nearest seed by list position (ties to the earlier).
  const auto sd = seeds();
  cell_.assign(candidates_.size(), 0);
  for (std::size_t c = 0, k = 0; c < candidates_.size(); ++c) {
    while (k + 1 < sd.size() && 2 * c > sd[k] + sd[k + 1]) ++k;
    cell_[c] = k;
  }
  linearise();
}

void ParameterDesign::linearise() {
  const auto& params = tmpl_->parameters();
  const std::size_t P = params.size(), C = grid_.size();
  std::vector<BsdfPtr> variants;
  std::vector<double> step(P);
  for (std::size_t j = 0; j < P; ++j) {
    const auto& q = params[j];
    double h = q.log_scale ? 0.02 * std::max(x_[j], q.lo) : 0.005 * (q.hi - q.lo);
    if (x_[j] + h > q.hi) h = -h;
    step[j] = h;
    auto x = x_;
    x[j] += h;
    variants.push_back(make_bsdf(tmpl_->spec(x), grid_));
  }
  EstimatorOptions est;
  est.rel_se = 1e-6;  // a fixed budget: every candidate on the same footing
  est.abs_se = 0;
  est.max_samples = options_.jacobian_samples;
  est.replicates = options_.jacobian_replicates;
  est.first_points = 64;
  est.seed = options_.fit.seed;
  const Twin twin(profile_, make_bsdf(tmpl_->spec(x_), grid_), grid_);
  const auto pred = twin.predict_variants(candidates_, variants, est, options_.threads);
  const auto noise = noise_of(data_);
  const std::size_t N = candidates_.size();
  jac_.assign(N, std::vector<double>(C * P));
  beta_.assign(N, {});
  w_read_.assign(N, std::vector<double>(C));
  for (std::size_t c = 0; c < N; ++c) {
    beta_[c] = pred[c][0].beta;
    for (std::size_t k = 0; k < C; ++k) {
      for (std::size_t j = 0; j < P; ++j) jac_[c][k * P + j] = (pred[c][1 + j].beta[k] - beta_[c][k]) / step[j];
      w_read_[c][k] = 1 / std::pow(noise.u(std::max(0.0, beta_[c][k])), 2);
    }
  }
  // Measured candidates weigh with the uncertainty they were read with.
  for (std::size_t m = 0; m < measured_.size(); ++m)
    for (std::size_t k = 0; k < C; ++k) w_read_[measured_[m]][k] = 1 / std::pow(data_.points[m].u[k], 2);
  // The choice's weights also carry the model's own uncertainty where the candidate lies.
  w_ = w_read_;
  for (std::size_t c = 0; c < N; ++c) {
    const double rel = options_.model_trust.relative_u(candidates_[c]);
    for (std::size_t k = 0; k < C; ++k) {
      const double um = rel * std::abs(beta_[c][k]);
      w_[c][k] = 1 / (1 / w_read_[c][k] + um * um);
    }
  }
  // A weak prior: a quarter of each parameter's range (of its logarithm for log-scale ones)
  // as one standard deviation, so that F is invertible before the data determine anything.
  prior_.assign(P, 0);
  for (std::size_t j = 0; j < P; ++j) {
    const auto& q = params[j];
    const double sd = q.log_scale ? std::max(x_[j], q.lo) * std::log(q.hi / q.lo) / 4 : (q.hi - q.lo) / 4;
    prior_[j] = 1 / (sd * sd);
  }
}

std::vector<double> ParameterDesign::information(const std::vector<std::size_t>& extra, bool readings_only) const {
  const std::size_t P = x_.size(), C = grid_.size();
  // A fit that misses (χ²/dof > 1) inflates its u by √(χ²/dof); the information is deflated alike.
  const double scale = fit_ ? 1 / std::max(1.0, fit_->chi2_per_dof) : 1.0;
  const auto& weights = readings_only ? w_read_ : w_;
  Eigen::MatrixXd F = Eigen::MatrixXd::Zero(static_cast<long>(P), static_cast<long>(P));
  const auto add = [&](std::size_t c) {
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(
        jac_[c].data(), static_cast<long>(C), static_cast<long>(P));
    const Eigen::Map<const Eigen::VectorXd> w(weights[c].data(), static_cast<long>(C));
    F.noalias() += scale * J.transpose() * w.asDiagonal() * J;
  };
  for (const auto c : measured_) add(c);
  for (const auto c : extra) add(c);
  for (std::size_t j = 0; j < P; ++j) F(static_cast<long>(j), static_cast<long>(j)) += prior_[j];
  const Eigen::MatrixXd inv = F.llt().solve(Eigen::MatrixXd::Identity(static_cast<long>(P), static_cast<long>(P)));
  return {inv.data(), inv.data() + inv.size()};
}

double ParameterDesign::log_det_gain(const std::vector<double>& info_inv, std::size_t c) const {
  const long P = static_cast<long>(x_.size()), C = static_cast<long>(grid_.size());
  const double scale = fit_ ? 1 / std::max(1.0, fit_->chi2_per_dof) : 1.0;
  const Eigen::Map<const Eigen::MatrixXd> Finv(info_inv.data(), P, P);
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(jac_[c].data(), C, P);
  const Eigen::Map<const Eigen::VectorXd> w(w_[c].data(), C);
  const Eigen::MatrixXd dF = scale * J.transpose() * w.asDiagonal() * J;
  // det(F + ΔF)/det F = det(I + F⁻¹ΔF); its eigenvalues are real and ≥ 1.
  const Eigen::MatrixXd M = Eigen::MatrixXd::Identity(P, P) + Finv * dF;
  return std::log(std::max(1.0, M.partialPivLu().determinant()));
}

struct ParameterDesign::Coverage {
  std::vector<Eigen::MatrixXd> cells;
  Eigen::MatrixXd total;
  std::size_t dominant = 0;
};

namespace {

// J_cᵀ W_c J_c of one candidate (J row-major, channels × parameters).
Eigen::MatrixXd point_information(const std::vector<double>& jac, const std::vector<double>& w, long P) {
  const long C = static_cast<long>(w.size());
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(jac.data(), C, P);
  const Eigen::Map<const Eigen::VectorXd> wv(w.data(), C);
  return J.transpose() * wv.asDiagonal() * J;
}

}  // namespace

ParameterDesign::Coverage ParameterDesign::coverage(const std::vector<std::size_t>& pending) const {
  const long P = static_cast<long>(x_.size());
  Coverage cov;
  cov.cells.assign(cell_.empty() ? 1 : cell_.back() + 1, Eigen::MatrixXd::Zero(P, P));
  for (const auto q : measured_) cov.cells[cell_[q]] += point_information(jac_[q], w_[q], P);
  for (const auto q : pending) cov.cells[cell_[q]] += point_information(jac_[q], w_[q], P);
  // The prior keeps F invertible; its share is nobody's.
  cov.total = Eigen::MatrixXd::Zero(P, P);
  for (const auto& f : cov.cells) cov.total += f;
  for (long j = 0; j < P; ++j) cov.total(j, j) += prior_[static_cast<std::size_t>(j)];
  const auto llt = cov.total.llt();
  double most = -1;
  for (std::size_t k = 0; k < cov.cells.size(); ++k)
    if (const double share = llt.solve(cov.cells[k]).trace(); share > most) {
      most = share;
      cov.dominant = k;
    }
  return cov;
}

bool ParameterDesign::keeps_coverage(const Coverage& cov, std::size_t c) const {
  // Only the cell that gives the most already is held to the cap: the others may grow
  // until they are that cell. Its share: trace(F⁻¹ F_cell)/P.
  if (options_.max_cell_share >= 1 || cell_[c] != cov.dominant) return true;
  const auto dF = point_information(jac_[c], w_[c], static_cast<long>(x_.size()));
  const Eigen::MatrixXd F = cov.total + dF, Fcell = cov.cells[cell_[c]] + dF;
  return F.llt().solve(Fcell).trace() / static_cast<double>(x_.size()) <= options_.max_cell_share;
}

std::optional<std::size_t> ParameterDesign::next(const std::vector<std::size_t>& pending,
                                                 const Geometry& arms) const {
  // Once the points in hand and pending will do, by the linearised design and the readings'
  // u (what the refit will state), no more: the refit with the pending points decides
  // (target_reached), and the loop asks again if not.
  if (fit_ && !pending.empty() && fit_->chi2_per_dof <= options_.fit.misfit_limit) {
    const auto inv = information(pending, true);
    const std::size_t P = x_.size();
    const double inflate = std::max(1.0, fit_->chi2_per_dof);
    bool enough = true;
    for (std::size_t j = 0; j < P; ++j)
      enough = enough && std::sqrt(inv[j * P + j] * inflate) <= options_.target_rel_u * std::abs(x_[j]);
    if (enough) return std::nullopt;
  }
  const auto inv = information(pending);
  if (options_.spread_on_misfit && fit_ && fit_->chi2_per_dof > options_.fit.misfit_limit)
    return widest_gap(inv, pending, arms);
  const auto cov = coverage(pending);
  // The most information per second; among the candidates that keep the seeds' coverage
  // when there are any.
  std::optional<std::size_t> best, best_covering;
  double best_score = -1, best_covering_score = -1;
  for (std::size_t c = 0; c < candidates_.size(); ++c) {
    if (!available(c, pending) || !movable(arms, c)) continue;
    const double seconds = std::max(1e-3, options_.timing.point_s(arms, candidates_[c]));
    const double score = log_det_gain(inv, c) / seconds;
    if (score > best_score) {
      best_score = score;
      best = c;
    }
    if (score > best_covering_score && keeps_coverage(cov, c)) {
      best_covering_score = score;
      best_covering = c;
    }
  }
  return best_covering ? best_covering : best;
}

namespace {

// The larger of the angles between two geometries' incidence and receiving directions, in
// degrees: how far apart two readings look at the sample.
double separation(const Geometry& a, const Geometry& b) {
  const auto angle = [](const std::array<double, 3>& u, const std::array<double, 3>& v) {
    const double c = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    return std::acos(std::clamp(c, -1.0, 1.0)) * 180 / std::numbers::pi;
  };
  return std::max(angle(a.incident_direction(), b.incident_direction()),
                  angle(a.receiving_direction(), b.receiving_direction()));
}

}  // namespace

std::optional<std::size_t> ParameterDesign::widest_gap(const std::vector<double>& info_inv,
                                                       const std::vector<std::size_t>& pending,
                                                       const Geometry& arms) const {
  // Nearly maximin (after Johnson, Moore & Ylvisaker, J. Statist. Plann. Inference 26
  // (1990) 131): among the candidates at least three quarters as far from every point
  // measured or pending as the farthest one, the quickest to reach (the model that misses
  // is no guide to which is worth more; information breaks ties). The points stay spread as
  // a maximin design's are, and the arms sweep each level of gaps instead of crossing the
  // range for every point. (Half as far: less travel, but the estimate strayed nearly twice
  // as far from the uniform scan's.)
  std::vector<double> gaps(candidates_.size(), -1);
  double widest = -1;
  for (std::size_t c = 0; c < candidates_.size(); ++c) {
    if (!available(c, pending) || !movable(arms, c)) continue;
    double gap = 1e300;
    for (const auto q : measured_) gap = std::min(gap, separation(candidates_[c], candidates_[q]));
    for (const auto q : pending) gap = std::min(gap, separation(candidates_[c], candidates_[q]));
    gaps[c] = gap;
    widest = std::max(widest, gap);
  }
  std::optional<std::size_t> best;
  double best_seconds = 0, best_gain = -1;
  for (std::size_t c = 0; c < candidates_.size(); ++c) {
    if (gaps[c] < 0 || gaps[c] < 0.75 * widest - 1e-9) continue;
    const double seconds = options_.timing.point_s(arms, candidates_[c]);
    const double gain = log_det_gain(info_inv, c);
    if (!best || seconds < best_seconds - 1e-9 || (seconds < best_seconds + 1e-9 && gain > best_gain)) {
      best_seconds = seconds;
      best_gain = gain;
      best = c;
    }
  }
  return best;
}

std::vector<std::size_t> ParameterDesign::seeds() const {
  // Spread over the candidates in their order (a sweep): a D-optimal start from the prior
  // would put every seed where the prior's model is most sensitive, and a model that is
  // exact there could look determined before the data could show that it misfits.
  const std::size_t N = candidates_.size();
  const std::size_t n = std::min(N, std::max<std::size_t>(5, 2 * x_.size() + 3));
  std::vector<std::size_t> chosen;
  for (std::size_t k = 0; k < n; ++k) {
    const auto c = n == 1 ? 0 : static_cast<std::size_t>(std::lround(static_cast<double>(k * (N - 1)) / static_cast<double>(n - 1)));
    if (chosen.empty() || chosen.back() != c) chosen.push_back(c);
  }
  return chosen;
}

void ParameterDesign::add(std::size_t c, const MeasuredPoint& p) {
  if (p.beta.size() != grid_.size() || p.u.size() != grid_.size())
    throw Error::invalid("point", fmt::format("has {} values for {} wavelengths", p.beta.size(), grid_.size()));
  mark(c);
  auto q = p;
  q.geometry = candidates_[c];
  data_.points.push_back(std::move(q));
}

void ParameterDesign::update() {
  if (data_.points.empty()) return;
  auto f = options_.fit;
  f.naive = false;
  if (fit_) {
    f.start = x_;  // warm: the last estimate is near
    f.starts = 1;
  }
  try {
    fit_ = fit_material(data_, model_, profile_, f);
    for (std::size_t j = 0; j < x_.size(); ++j) x_[j] = fit_->parameters[j].value;
    note_.clear();
  } catch (const Error& e) {
    // Keep the last estimate; the next point may make the problem solvable.
    note_ = fmt::format("the fit on {} points failed: {}", data_.points.size(), e.what());
  }
  linearise();
}

bool ParameterDesign::target_reached() const {
  // Not before every seed is in: the spread is what lets a misfit show.
  if (!fit_ || fit_->points < std::min(candidates_.size(), std::max<std::size_t>(5, 2 * x_.size() + 3)) ||
      fit_->chi2_per_dof > options_.fit.misfit_limit)
    return false;
  return std::all_of(fit_->parameters.begin(), fit_->parameters.end(), [&](const FittedParameter& p) {
    return !p.at_bound && p.identifiable && std::isfinite(p.u) && p.u <= options_.target_rel_u * std::abs(p.value);
  });
}

DesignStatus ParameterDesign::status() const {
  DesignStatus s;
  s.mode = AdaptiveMode::parameters;
  s.state = target_reached() ? DesignState::target_reached : DesignState::running;
  s.points_used = measured_.size();
  if (fit_) {
    for (const auto& p : fit_->parameters) s.parameters.push_back({p.name, p.value, p.u});
    s.chi2_per_dof = fit_->chi2_per_dof;
    s.misfit = fit_->chi2_per_dof > options_.fit.misfit_limit;
    s.warnings = fit_->warnings;
  }
  if (!note_.empty()) s.warnings.insert(s.warnings.begin(), note_);
  return s;
}

}  // namespace gonio::twin
