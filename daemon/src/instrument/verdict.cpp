// The scan's verdict from all of its points (see verdict.hpp).
#include "gonio/daemon/instrument/verdict.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <boost/math/special_functions/gamma.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/daemon/instrument/divergence.hpp"

namespace gonio::daemon {
namespace {

constexpr auto npos = std::string::npos;

// The accumulated matrices are stored as plain vectors (the header stays free of Eigen) and
// worked on through maps.
using Matrix = Eigen::Map<Eigen::MatrixXd>;
using ConstMatrix = Eigen::Map<const Eigen::MatrixXd>;
using ConstVector = Eigen::Map<const Eigen::VectorXd>;
Matrix view(std::vector<double>& v, std::size_t n) {
  return Matrix(v.data(), static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
}
ConstMatrix view(const std::vector<double>& v, std::size_t n) {
  return ConstMatrix(v.data(), static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
}
ConstVector view(const std::vector<double>& v) { return ConstVector(v.data(), static_cast<Eigen::Index>(v.size())); }
// bᵀ M b
double form(const std::vector<double>& m, std::size_t n, const std::vector<double>& b) {
  return view(b).dot(view(m, n) * view(b));
}

// P(χ² ≥ x) for `dof` degrees of freedom (the upper regularised incomplete gamma function).
double chi2_p_value(double x, double dof) {
  if (!(x > 0)) return 1.0;
  if (!std::isfinite(x)) return 0.0;
  return boost::math::gamma_q(dof / 2, x / 2);
}

// "lambert.albedo@600" → ("lambert.albedo", 600); nullopt for a scalar parameter.
std::optional<std::pair<std::string, double>> spectral_node(const std::string& name) {
  const auto at = name.rfind('@');
  if (at == std::string::npos) return std::nullopt;
  try {
    std::size_t used = 0;
    const double nm = std::stod(name.substr(at + 1), &used);
    if (used != name.size() - at - 1) return std::nullopt;
    return std::make_pair(name.substr(0, at), nm);
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

double limit_of(const BudgetEntry& e, double u, double k) {
  if (e.distribution == "rectangular") return std::sqrt(3.0) * u;
  if (e.distribution == "triangular") return std::sqrt(6.0) * u;
  return k * u;
}

// What an instrument input is, in the verdict's words.
std::string describe(const VerdictCause& c) {
  if (c.band_nm)
    return fmt::format("{} {:g}–{:g} nm scaled by {:.4f} ± {:.4f} ({:+.1f} %)", c.parameter.substr(0, c.parameter.rfind('@')),
                       (*c.band_nm)[0], (*c.band_nm)[1], c.value, c.u, 100 * (c.value - 1));
  if (c.parameter == "position_repeatability_deg")
    return fmt::format("random arm scatter of {:.3f} ± {:.3f}° per move (stated {:.3f}°)", c.value, c.u, c.nominal);
  if (c.kind == "sample")
    return fmt::format("{} = {:.4g} ± {:.2g} (catalogued {:.4g})", c.parameter, c.value, c.u, c.nominal);
  if (c.parameter == "incidence_arm_deg")
    return fmt::format("an incidence-arm offset of {:+.3f} ± {:.3f}°", c.value, c.u);
  if (c.parameter == "receive_arm_deg")
    return fmt::format("a receive-arm offset of {:+.3f} ± {:.3f}°", c.value, c.u);
  if (c.parameter == "gain") return fmt::format("a reference-white gain of {:.4f} ± {:.4f}", c.value, c.u);
  if (c.parameter == "source_aperture_rel")
    return fmt::format("a source aperture {:.3f} ± {:.3f} × its stated size", c.value, c.u);
  return fmt::format("a receiver aperture {:.3f} ± {:.3f} × its stated size", c.value, c.u);
}

}  // namespace

nlohmann::json ScanVerdict::to_json() const {
  const auto cause_json = [](const std::optional<VerdictCause>& c) -> nlohmann::json {
    if (!c) return nullptr;
    nlohmann::json j{{"kind", c->kind}, {"parameter", c->parameter}, {"value", c->value},
                     {"u", c->u},       {"nominal", c->nominal}};
    if (c->band_nm) {
      j["band_nm"] = {(*c->band_nm)[0], (*c->band_nm)[1]};
      j["scale"] = c->value;
    }
    return j;
  };
  nlohmann::json alike_json = nlohmann::json::array();
  for (const auto& a : alike) alike_json.push_back(cause_json(a));
  nlohmann::json candidates_json = nlohmann::json::array();
  for (const auto& c : candidates) {
    auto j = cause_json(c.cause);
    j["delta_chi2"] = c.delta_chi2;
    candidates_json.push_back(std::move(j));
  }
  nlohmann::json regions_json = nlohmann::json::array();
  for (const auto& r : regions)
    regions_json.push_back({{"theta_i", r.theta_i},
                            {"aspecular", {r.aspecular_lo, r.aspecular_hi}},
                            {"points", r.points},
                            {"chi2_per_n", r.chi2_per_n},
                            {"mean_rel", r.mean_rel},
                            {"u", r.u},
                            {"decision", decision_text(r.decision)}});
  return nlohmann::json{{"decision", decision},
                        {"summary", summary},
                        {"cause", cause_json(cause)},
                        {"calibration_hint", cause_json(calibration_hint)},
                        {"explained", explained},
                        {"p_value", p_value},
                        {"chi2_per_dof", chi2_per_dof},
                        {"points_used", points_used},
                        {"delta_chi2_next", delta_chi2_next},
                        {"alike", std::move(alike_json)},
                        {"candidates", std::move(candidates_json)},
                        {"regions", std::move(regions_json)}};
}

void ScanEvidence::setup(const PointRecord& p) {
  channels_ = p.measured.size();
  for (const auto& e : p.budget) {
    if (e.component == "arm_repeatability_deg" && !e.u.empty()) repeatability_u_ = e.u.front();
    if (e.random) continue;
    Column c;
    c.kind = "instrument";
    c.unit = e.unit;
    double ss = 0;
    for (double u : e.u) ss += u * u;
    c.prior_u = e.u.empty() ? 0 : std::sqrt(ss / static_cast<double>(e.u.size()));
    c.limit = limit_of(e, c.prior_u, k_);
    c.name = e.component == "reference_white_rel" ? "gain" : e.component;
    c.nominal = e.unit == "deg" ? 0.0 : 1.0;
    // β is proportional to the gain (exact); arm offsets are differenced at ±their limit and
    // stay near-linear over a few of them; an aperture's 3 % step says little about 2×.
    c.max_change = c.name == "gain" ? 0.5 : e.unit == "deg" ? 4 * c.limit : 5 * c.limit;
    c.curved = !e.curvature.empty();
    c.bounded = e.distribution != "normal";
    if (c.prior_u > 0) names_.push_back(c);
  }
  for (const auto& s : p.sample_sensitivity) {
    Column c;
    c.name = s.parameter;
    c.kind = "sample";
    c.nominal = s.value;
    c.max_change = s.value != 0 ? std::abs(s.value) : std::numeric_limits<double>::infinity();
    names_.push_back(std::move(c));
  }
  add_bands(p.measured.wavelengths);
  const auto n = names_.size();
  for (std::size_t j = 0; j < n; ++j)
    if (names_[j].kind == "sample") sample_columns_.push_back(j);
  curvature_of_.assign(n, npos);
  cross_of_.assign(n, npos);
  partner_.assign(n, npos);
  std::size_t e = n;
  for (std::size_t j = 0; j < n; ++j)
    if (names_[j].curved) curvature_of_[j] = e++;
  const auto column_of = [&](const std::string& component) {
    const auto name = component == "reference_white_rel" ? std::string("gain") : component;
    for (std::size_t j = 0; j < n; ++j)
      if (names_[j].name == name) return j;
    return npos;
  };
  for (const auto& b : p.budget) {
    if (b.cross.empty()) continue;
    const auto j = column_of(b.component), k = column_of(b.cross_with);
    if (j == npos || k == npos || j == k) continue;
    partner_[j] = k;
    cross_of_[j] = e++;
  }
  residual_ = e++;
  E_ = e;
  G_.assign(e * e, 0.0);
  Zw_ = Zs_ = Lag_ = G_;
  const std::size_t bands = std::min<std::size_t>(3, channels_);
  bands_.assign(bands, Moments{0, 0, std::vector<double>(n, 0.0), std::vector<double>(n, 0.0),
                               std::vector<double>(n, 0.0)});
  band_of_.assign(channels_, 0);
  for (std::size_t b = 0; b < bands; ++b)
    for (std::size_t c = b * channels_ / bands; c < (b + 1) * channels_ / bands; ++c) band_of_[c] = b;
}

// A spectral parameter's nodes as contiguous bands moving together, the whole spectrum
// included: one column each, whose θ is the band's relative change.
void ScanEvidence::add_bands(const WavelengthGrid& wavelengths) {
  std::map<std::string, std::vector<std::pair<double, std::size_t>>> spectra;
  for (std::size_t j = 0; j < names_.size(); ++j)
    if (names_[j].kind == "sample")
      if (const auto node = spectral_node(names_[j].name)) spectra[node->first].emplace_back(node->second, j);
  for (auto& [prefix, nodes] : spectra) {
    std::sort(nodes.begin(), nodes.end());
    for (std::size_t lo = 0; lo < nodes.size(); ++lo)
      for (std::size_t hi = lo + 1; hi < nodes.size(); ++hi) {
        Column c;
        c.name = fmt::format("{}@{:g}-{:g}", prefix, nodes[lo].first, nodes[hi].first);
        c.kind = "sample";
        c.nominal = 1.0;
        c.max_change = 1.0;
        for (std::size_t i = lo; i <= hi; ++i) c.members.push_back(nodes[i].second);
        c.band_lo = nodes[lo].first;
        c.band_hi = nodes[hi].first;
        names_.push_back(std::move(c));
      }
  }
  // A catalogue with no parameter at all (a master, a table): β itself over the verdict's
  // wavelength bands (up to three, as band_of_ splits the channels), contiguous runs of them.
  // A formula's change is one of its parameters; a scale of its β is not one (and would tie
  // with the white's gain wherever the formula has no spectral parameter).
  const bool has_parameters = std::any_of(names_.begin(), names_.end(), [](const Column& c) { return c.kind == "sample"; });
  if (has_parameters || wavelengths.size() == 0) return;
  const std::size_t channels = wavelengths.size(), bands = std::min<std::size_t>(3, channels);
  for (std::size_t lo = 0; lo < bands; ++lo)
    for (std::size_t hi = lo; hi < bands; ++hi) {
      Column c;
      c.first_channel = lo * channels / bands;
      c.last_channel = (hi + 1) * channels / bands;
      c.band_lo = wavelengths[c.first_channel];
      c.band_hi = wavelengths[c.last_channel - 1];
      c.name = fmt::format("catalogue@{:g}-{:g}", c.band_lo, c.band_hi);
      c.kind = "sample";
      c.nominal = 1.0;
      c.max_change = 1.0;
      names_.push_back(std::move(c));
    }
}

ScanEvidence::Region& ScanEvidence::region_of(const Geometry& g) {
  const double ti = std::round(g.theta_i * 10) / 10;
  const int bin = static_cast<int>(std::floor((g.theta_i - g.theta_r) / kRegionDeg));
  for (auto& r : regions_)
    if (r.theta_i == ti && r.bin == bin) return r;
  const auto n = names_.size();
  Region r;
  r.theta_i = ti;
  r.bin = bin;
  r.moments = Moments{0, 0, std::vector<double>(n, 0.0), std::vector<double>(n, 0.0), std::vector<double>(n, 0.0)};
  r.G.assign(E_ * E_, 0.0);
  regions_.push_back(std::move(r));
  return regions_.back();
}

void ScanEvidence::add_scatter_terms(std::vector<double> a, double q) {
  for (auto& x : a) x /= std::sqrt(q);
  // Each point weighs q/(1 + σ0²q)², the inverse of var z² = 2(1 + σ²q)² at σ² = σ0², a
  // scatter of twice the stated repeatability: weights ∝ q alone would let the few points on a
  // steep flank, whose z² is the noisiest, decide the estimate.
  const double s0 = 4 * std::max(repeatability_u_ * repeatability_u_, kMinScatterVar);
  const double w = q / ((1 + s0 * q) * (1 + s0 * q));
  const auto A = view(a);
  view(Zw_, E_).noalias() += w * A * A.transpose();
  view(Zs_, E_).noalias() += A * A.transpose();
  if (previous_a_.size() == a.size()) view(Lag_, E_).noalias() += A * view(previous_a_).transpose();
  previous_a_ = std::move(a);
  sum_w_ += w;
  sum_wq_ += w * q;
  sum_w2_ += w * w;
  sum_w2q_ += w * w * q;
  sum_w2q2_ += w * w * q * q;
}

void ScanEvidence::add(const PointRecord& rec) {
  if (!rec.predicted || rec.budget.empty()) return;
  if (names_.empty()) setup(rec);
  const auto& m = rec.measured;
  const auto& q = *rec.predicted;
  if (m.size() != channels_ || q.size() != channels_) return;
  const auto n = names_.size();
  std::vector<std::vector<double>> columns(n), curvature(n), cross(n);
  std::vector<double> arm_scatter;  // ∂β/∂(one move) per channel: the repeatability's sensitivity
  for (const auto& e : rec.budget)
    if (e.component == "arm_repeatability_deg" && e.sensitivity.size() == channels_) arm_scatter = e.sensitivity;
  for (std::size_t j = 0; j < n; ++j) {
    const auto& col = names_[j];
    std::vector<double> v(channels_, 0.0);
    if (col.last_channel > col.first_channel) {
      for (std::size_t c = col.first_channel; c < col.last_channel; ++c) v[c] = q.values[c];
    } else if (!col.members.empty()) {
      for (const auto k : col.members)
        for (std::size_t c = 0; c < channels_; ++c) v[c] += names_[k].nominal * columns[k][c];
    } else if (col.kind == "sample") {
      for (const auto& s : rec.sample_sensitivity)
        if (s.parameter == col.name && s.sensitivity.size() == channels_) v = s.sensitivity;
    } else {
      const auto component = col.name == "gain" ? std::string("reference_white_rel") : col.name;
      for (const auto& e : rec.budget)
        if (e.component == component && e.sensitivity.size() == channels_) {
          v = e.sensitivity;
          if (cross_of_[j] != npos) cross[j] = e.cross.size() == channels_ ? e.cross : std::vector<double>(channels_, 0.0);
          if (col.curved) curvature[j] = e.curvature.size() == channels_ ? e.curvature : std::vector<double>(channels_, 0.0);
        }
      if (col.curved && curvature[j].empty()) curvature[j].assign(channels_, 0.0);
      if (cross_of_[j] != npos && cross[j].empty()) cross[j].assign(channels_, 0.0);
    }
    columns[j] = std::move(v);
  }
  Region& region = region_of(rec.planned);
  ++region.points;
  const auto E = static_cast<Eigen::Index>(E_);
  Eigen::VectorXd ext = Eigen::VectorXd::Zero(E), a = Eigen::VectorXd::Zero(E);
  auto G = view(G_, E_);
  auto RG = view(region.G, E_);
  double aq = 0;
  const auto add_moments = [&](Moments& mo, double pv, double r, std::size_t c) {
    mo.pp += pv * q.values[c];
    mo.pr += pv * r;
    for (std::size_t j = 0; j < n; ++j) {
      mo.ps[j] += pv * columns[j][c];
      if (!curvature[j].empty()) mo.pc2[j] += pv * curvature[j][c];
      if (!cross[j].empty()) mo.px[j] += pv * cross[j][c];
    }
  };
  Decision own = Decision::agrees;  // the point judged alone, as the per-point rule does
  for (std::size_t c = 0; c < channels_; ++c) {
    double var = m.std_uncertainty[c] * m.std_uncertainty[c] + q.std_uncertainty[c] * q.std_uncertainty[c];
    double systematic = 0;
    for (const auto& e : rec.budget)
      if (c < e.contribution.size()) (e.random ? var : systematic) += e.contribution[c] * e.contribution[c];
    const double r = m.values[c] - q.values[c];
    own = worse(own, decide(r, std::sqrt(var + systematic), tolerance_ * std::abs(q.values[c]), k_));
    if (!(var > 0)) continue;
    const double w = 1.0 / var;
    for (std::size_t j = 0; j < n; ++j) {
      ext[static_cast<Eigen::Index>(j)] = columns[j][c];
      if (curvature_of_[j] != npos) ext[static_cast<Eigen::Index>(curvature_of_[j])] = curvature[j][c];
      if (cross_of_[j] != npos) ext[static_cast<Eigen::Index>(cross_of_[j])] = cross[j][c];
    }
    ext[static_cast<Eigen::Index>(residual_)] = r;
    G.noalias() += w * ext * ext.transpose();
    RG.noalias() += w * ext * ext.transpose();
    ++n_;
    ++region.channels;
    if (!arm_scatter.empty() && arm_scatter[c] != 0) {
      a += arm_scatter[c] * w * ext;
      aq += arm_scatter[c] * arm_scatter[c] * w;
    }
    const double pv = q.values[c] * w;
    if (pv == 0 || bands_.empty()) continue;
    add_moments(bands_[band_of_[c]], pv, r, c);
    add_moments(region.moments, pv, r, c);
  }
  if (own == Decision::out_of_tolerance) ++points_out_;
  if (aq > 0) add_scatter_terms(std::vector<double>(a.data(), a.data() + E), aq);
  for (const auto j : sample_columns_) {
    double margin = std::numeric_limits<double>::infinity();
    for (std::size_t c = 0; c < channels_; ++c)
      if (const double sens = std::abs(columns[j][c]); sens > 0)
        margin = std::min(margin, tolerance_ * std::abs(q.values[c]) / sens);
    margins_.push_back(margin);
  }
  ++points_;
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
  const auto objective = [&](const std::vector<double>& th) {
    double chi2 = form(G_, E_, coefficients(columns, th));
    for (std::size_t i = 0; i < n; ++i) chi2 += prior[static_cast<Eigen::Index>(i)] * th[i] * th[i];
    return chi2;
  };
  // A rectangular (or triangular) input held to its data sheet cannot lie beyond ±its limit:
  // a hard bound beside the normal penalty (projected Gauss–Newton with an active set).
  std::vector<double> bound(n, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    if (prior[static_cast<Eigen::Index>(i)] > 0 && names_[columns[i]].bounded) bound[i] = names_[columns[i]].limit;
  std::vector<int> at_bound(n, 0);  // −1, +1: held at −/+bound
  std::vector<double> theta(n, 0.0);
  Eigen::MatrixXd inv;
  double chi2 = objective(theta);
  bool solved = false;
  // The normal equations at theta: M = Γᵀ G Γ + priors and the descent direction, with Γ the
  // derivatives of the model f over the extended columns (∂f/∂θ_i).
  const auto normal_equations = [&](Eigen::MatrixXd& M, Eigen::VectorXd& rhs) {
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
    M = gamma.transpose() * Gg;
    M.diagonal() += prior;
    rhs = Gg.transpose() * beta;
    for (std::size_t i = 0; i < n; ++i) rhs[static_cast<Eigen::Index>(i)] -= prior[static_cast<Eigen::Index>(i)] * theta[i];
  };
  for (int iter = 0; iter < 40; ++iter) {
    Eigen::MatrixXd M;
    Eigen::VectorXd rhs;
    normal_equations(M, rhs);
    for (std::size_t i = 0; i < n; ++i)
      if (at_bound[i] != 0) {
        const auto I = static_cast<Eigen::Index>(i);
        M.row(I).setZero();
        M.col(I).setZero();
        M(I, I) = 1;
      }
    const Eigen::VectorXd raw_rhs = rhs;
    for (std::size_t i = 0; i < n; ++i)
      if (at_bound[i] != 0) rhs[static_cast<Eigen::Index>(i)] = 0;
    const Eigen::LLT<Eigen::MatrixXd> llt(M);
    if (llt.info() != Eigen::Success || !(M.diagonal().minCoeff() > 1e-300)) break;
    inv = llt.solve(Eigen::MatrixXd::Identity(N, N));
    solved = true;
    const Eigen::VectorXd step = inv * rhs;
    const double size = n ? step.cwiseAbs().maxCoeff() : 0.0;
    // Halve the step until χ² does not rise (the quadratic terms can overshoot); clamp to
    // the bounds, and hold what reaches one there.
    double t = 1;
    std::vector<double> next(n);
    std::vector<int> hits(n, 0);
    bool moved = false;
    for (int h = 0; h < 20; ++h, t /= 2) {
      for (std::size_t i = 0; i < n; ++i) {
        next[i] = theta[i] + t * step[static_cast<Eigen::Index>(i)];
        hits[i] = 0;
        if (bound[i] > 0 && std::abs(next[i]) > bound[i]) {
          hits[i] = next[i] > 0 ? 1 : -1;
          next[i] = hits[i] * bound[i];
        }
      }
      if (const double c = objective(next); c <= chi2 + 1e-12 * std::abs(chi2)) {
        theta = next;
        chi2 = c;
        moved = true;
        for (std::size_t i = 0; i < n; ++i)
          if (hits[i] != 0) at_bound[i] = hits[i];
        break;
      }
    }
    if (moved && t * size >= 1e-9 * (1 + size)) continue;
    // Converged on the free set: release a held input whose descent points back inside.
    bool released = false;
    for (std::size_t i = 0; i < n; ++i)
      if (at_bound[i] != 0 && raw_rhs[static_cast<Eigen::Index>(i)] * at_bound[i] < 0) {
        at_bound[i] = 0;
        released = true;
      }
    if (!released) break;
  }
  if (!solved) {
    f.chi2 = std::numeric_limits<double>::infinity();
    return f;
  }
  f.theta = theta;
  f.u.assign(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    const auto I = static_cast<Eigen::Index>(i);
    f.u[i] = at_bound[i] != 0 ? 0.0 : std::sqrt(std::max(0.0, inv(I, I)));
  }
  f.chi2 = chi2;
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

std::string ScanEvidence::tolerance_text() const {
  return fmt::format("±{:g} % (k = {:g})", 100 * tolerance_, k_);
}

namespace {
std::string in_words(Decision d) {
  return d == Decision::agrees ? "within tolerance" : d == Decision::out_of_tolerance ? "out of tolerance" : "not decided";
}
std::string short_text(Decision d) {
  return d == Decision::agrees ? "agrees" : d == Decision::out_of_tolerance ? "out of tolerance" : "undecided";
}
}  // namespace

// A candidate's own decision (for the named cause and for ties), and the sentence that says why.
std::string ScanEvidence::decide_for(const Fitted& c, std::string& text) const {
  const auto cause = cause_of(c);
  if (cause.kind == "instrument") {
    const auto& col = names_[c.column];
    const double off = std::abs(cause.value - cause.nominal);
    if (off - k_ * cause.u > col.limit) {
      text = fmt::format("the instrument is outside its datasheet: {} (stated ±{:.3g}{})", describe(cause),
                         col.limit, col.unit == "deg" ? "°" : "");
      return "instrument_out_of_spec";
    }
    const auto b = band_decision(c.fit);
    text = fmt::format("{} within the datasheet explains the points; with it removed the sample is {} "
                       "(worst band {:+.2f} ± {:.2f} %, tolerance {})",
                       describe(cause), in_words(b.decision), 100 * b.worst_rel, 100 * b.worst_u, tolerance_text());
    return decision_text(b.decision);
  }
  std::size_t out_points = 0;
  const auto d = effect_decision(c, out_points);
  text = fmt::format("the sample differs from its catalogue: {}; {}", describe(cause),
                     d == Decision::out_of_tolerance
                         ? fmt::format("beyond the tolerance {} at {} of {} points", tolerance_text(), out_points,
                                       points_)
                     : d == Decision::agrees ? fmt::format("within the tolerance {} at every point", tolerance_text())
                                             : fmt::format("not decidable against the tolerance {}", tolerance_text()));
  return decision_text(d);
}

// No candidate explains the residuals: no cause is named. The scan is judged on the bands and
// the regions under `fit` (the catalogue with the instrument within its data sheet), their
// uncertainty scaled by the misfit, and the worst regions are listed.
void ScanEvidence::unexplained(ScanVerdict& v, const Fit& fit, const std::string& why) const {
  v.cause.reset();
  v.explained = false;
  v.chi2_per_dof = fit.chi2 / dof(fit.free.size());
  v.p_value = chi2_p_value(fit.chi2, dof(fit.free.size()));
  auto regions = regions_of(fit);
  const auto bands = band_decision(fit);
  Decision d = bands.decision;
  for (const auto& r : regions) d = worse(d, r.decision);
  // A departure confined to a few points is diluted in any mean: the points judged alone
  // (with the instrument's systematic inputs in their u) count too.
  if (points_out_ > 0) d = Decision::out_of_tolerance;
  if (regions.size() > 3) regions.resize(3);
  std::string where;
  for (const auto& r : regions)
    where += fmt::format("{}θi {:g}°, aspecular {:g}…{:g}°: {:+.2f} ± {:.2f} % (χ²/n {:.3g})", where.empty() ? "" : "; ",
                         r.theta_i, r.aspecular_lo, r.aspecular_hi, 100 * r.mean_rel, 100 * r.u, r.chi2_per_n);
  v.regions = std::move(regions);
  v.decision = decision_text(d);
  v.summary = fmt::format("{}: the sample does not match its catalogue; no single parameter explains it ({}; χ²/dof "
                          "{:.3g}, p = {:.2g}); worst regions: {}; {} of {} points out of tolerance on their own "
                          "(tolerance {})",
                          short_text(d), why, v.chi2_per_dof, v.p_value, where, points_out_, points_,
                          tolerance_text());
}

// Random scatter beyond the stated repeatability: an instrument cause and a calibration hint,
// not an alarm about the sample, which is judged per band with the scatter in its uncertainty.
void ScanEvidence::name_scatter(ScanVerdict& v, const Fit& h0, const Scatter& s) const {
  const double total = std::sqrt(repeatability_u_ * repeatability_u_ + s.extra_var);
  // u(σ) from u(σ²): dσ = dσ² / (2σ).
  VerdictCause cause{"instrument", "position_repeatability_deg", total, s.u_extra_var / (2 * total),
                     repeatability_u_, {}};
  const auto b = band_decision(h0);
  v.cause = cause;
  v.calibration_hint = cause;
  v.explained = true;
  v.chi2_per_dof = h0.chi2 / dof(0);
  v.p_value = chi2_p_value(h0.chi2, dof(0));
  v.decision = decision_text(b.decision);
  v.summary = fmt::format("{}: the residuals are random from point to point (lag-1 ρ {:.2f}): {} — a calibration "
                          "hint, not the sample; with it in the uncertainty the sample is {} (worst band {:+.2f} ± "
                          "{:.2f} %, tolerance {})",
                          short_text(b.decision), s.rho, describe(cause), in_words(b.decision), 100 * b.worst_rel,
                          100 * b.worst_u, tolerance_text());
}

// H0 (the instrument's inputs held to their data sheets) against one candidate cause at a
// time; the best, if it stands out by kSignificant, no other is within kTie of it and the χ²
// it leaves is consistent with its degrees of freedom, is named, and its decision is the
// scan's. Otherwise random scatter, or no cause (see verdict.hpp).
ScanVerdict ScanEvidence::verdict() const {
  ScanVerdict v;
  v.points_used = points_;
  const auto needed = std::max<std::size_t>(5, 2 * candidates());
  if (points_ < 3 || n_ == 0) {
    v.summary = fmt::format("{} points with predictions: a verdict needs 3, a named cause {}", points_,
                            needed);
    return v;
  }
  std::vector<std::size_t> instrument, sample;
  for (std::size_t j = 0; j < names_.size(); ++j) (names_[j].kind == "sample" ? sample : instrument).push_back(j);
  const auto h0 = solve(instrument, {});
  const bool early = points_ < needed;
  // Too few points for a cause: only the per-band test.
  const auto cands = early ? std::vector<Fitted>{} : fit_candidates(instrument, sample);
  for (const auto& c : cands) v.candidates.push_back({cause_of(c), h0.chi2 - c.fit.chi2});
  v.chi2_per_dof = h0.chi2 / dof(0);
  v.p_value = chi2_p_value(h0.chi2, dof(0));
  const bool h0_consistent = v.p_value >= kConsistent;
  const auto scatter = early || h0_consistent ? Scatter{} : scatter_of(h0);
  // Evidence: a candidate that lowers χ² by kSignificant. (H0 holds each rectangular input
  // within its stated limit, so an arm truly beyond it cannot hide in H0's prior.)
  const bool significant = !cands.empty() && std::isfinite(cands.front().fit.chi2) &&
                           h0.chi2 - cands.front().fit.chi2 > kSignificant;
  if (!significant) {
    if (scatter.named) {
      name_scatter(v, h0, scatter);
    } else if (early || h0_consistent) {
      const auto b = band_decision(h0);
      v.decision = decision_text(b.decision);
      v.explained = h0_consistent;
      v.summary = fmt::format("{} over {} points: the worst band differs by {:+.2f} ± {:.2f} % (tolerance {}); {} (χ²/dof {:.3g})",
                              short_text(b.decision), points_, 100 * b.worst_rel, 100 * b.worst_u, tolerance_text(),
                              early ? fmt::format("the cause is undetermined until {} points are in", needed)
                                    : std::string("no candidate cause stands out"),
                              v.chi2_per_dof);
    } else {
      unexplained(v, h0, "no candidate cause stands out");
    }
    return v;
  }
  const auto& best = cands.front();
  v.delta_chi2_next = cands.size() > 1 ? cands[1].fit.chi2 - best.fit.chi2 : 0;
  const double best_p = chi2_p_value(std::max(0.0, best.fit.chi2 - truncation_chi2(best)), dof(1));
  if (best_p < kConsistent) {
    // The best candidate improves on H0 but does not explain what is left: naming it would
    // blame one parameter for a misfit it does not account for.
    if (scatter.named)
      name_scatter(v, h0, scatter);
    else
      unexplained(v, h0, fmt::format("the best candidate, {}, leaves χ²/dof {:.3g}", describe(cause_of(best)),
                                     best.fit.chi2 / dof(1)));
    return v;
  }
  v.chi2_per_dof = best.fit.chi2 / dof(1);
  v.p_value = best_p;
  std::string text;
  v.decision = decide_for(best, text);
  std::vector<const Fitted*> tied;
  for (std::size_t i = 1; i < cands.size(); ++i)
    if (cands[i].fit.chi2 - best.fit.chi2 < kTie) tied.push_back(&cands[i]);
  if (!tied.empty()) {
    // The points cannot tell these apart: no cause is named. When every one of them alerts,
    // the measurement is out of tolerance whichever it is.
    std::string names = describe(cause_of(best));
    bool same = true, all_alert = v.decision == "out_of_tolerance" || v.decision == "instrument_out_of_spec";
    for (const auto* t : tied) {
      std::string other;
      const auto d = decide_for(*t, other);
      same = same && d == v.decision;
      all_alert = all_alert && (d == "out_of_tolerance" || d == "instrument_out_of_spec");
      v.alike.push_back(cause_of(*t));
      names += " or " + describe(v.alike.back());
    }
    v.alike.insert(v.alike.begin(), cause_of(best));
    if (!same) v.decision = all_alert ? "out_of_tolerance" : "undecided";
    v.summary = fmt::format("{}: the twin disagrees (χ²/dof {:.3g} → {:.3g}) but the points cannot tell {} "
                            "apart (undetermined cause)",
                            v.decision, h0.chi2 / dof(0), v.chi2_per_dof, names);
    return v;
  }
  v.cause = cause_of(best);
  if (v.cause->kind == "instrument" && v.decision != "instrument_out_of_spec" &&
      std::abs(v.cause->value - v.cause->nominal) - k_ * v.cause->u > 0) {
    v.calibration_hint = v.cause;
    v.cause.reset();  // an in-spec input is not what is wrong with the scan
  }
  v.summary = fmt::format("{}: {} (χ²/dof {:.3g} → {:.3g}, Δχ² {:.3g} over the next candidate)", v.decision, text,
                          h0.chi2 / dof(0), v.chi2_per_dof, v.delta_chi2_next);
  return v;
}

}  // namespace gonio::daemon
