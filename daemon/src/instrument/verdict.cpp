// The scan's verdict from all of its points (see verdict.hpp).
#include "gonio/daemon/instrument/verdict.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/daemon/instrument/divergence.hpp"

namespace gonio::daemon {
namespace {

// Cholesky solve of a small symmetric positive-definite system; false when it is not.
bool cholesky_inverse(std::vector<std::vector<double>> m, std::vector<std::vector<double>>& inv) {
  const std::size_t n = m.size();
  std::vector<std::vector<double>> L(n, std::vector<double>(n, 0.0));
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j <= i; ++j) {
      double s = m[i][j];
      for (std::size_t k = 0; k < j; ++k) s -= L[i][k] * L[j][k];
      if (i == j) {
        if (!(s > 1e-300)) return false;
        L[i][i] = std::sqrt(s);
      } else {
        L[i][j] = s / L[j][j];
      }
    }
  inv.assign(n, std::vector<double>(n, 0.0));
  for (std::size_t c = 0; c < n; ++c) {
    std::vector<double> y(n, 0.0), x(n, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      double s = i == c ? 1.0 : 0.0;
      for (std::size_t k = 0; k < i; ++k) s -= L[i][k] * y[k];
      y[i] = s / L[i][i];
    }
    for (std::size_t i = n; i-- > 0;) {
      double s = y[i];
      for (std::size_t k = i + 1; k < n; ++k) s -= L[k][i] * x[k];
      x[i] = s / L[i][i];
    }
    for (std::size_t i = 0; i < n; ++i) inv[i][c] = x[i];
  }
  return true;
}

double limit_of(const BudgetEntry& e, double u, double k) {
  if (e.distribution == "rectangular") return std::sqrt(3.0) * u;
  if (e.distribution == "triangular") return std::sqrt(6.0) * u;
  return k * u;
}

// What an instrument input is, in the verdict's words.
std::string describe(const VerdictCause& c) {
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
    return nlohmann::json{{"kind", c->kind}, {"parameter", c->parameter}, {"value", c->value},
                          {"u", c->u},       {"nominal", c->nominal}};
  };
  nlohmann::json alike_json = nlohmann::json::array();
  for (const auto& a : alike) alike_json.push_back(cause_json(a));
  nlohmann::json candidates_json = nlohmann::json::array();
  for (const auto& c : candidates) {
    auto j = cause_json(c.cause);
    j["delta_chi2"] = c.delta_chi2;
    candidates_json.push_back(std::move(j));
  }
  return nlohmann::json{{"decision", decision},
                        {"summary", summary},
                        {"cause", cause_json(cause)},
                        {"calibration_hint", cause_json(calibration_hint)},
                        {"chi2_per_dof", chi2_per_dof},
                        {"points_used", points_used},
                        {"delta_chi2_next", delta_chi2_next},
                        {"alike", std::move(alike_json)},
                        {"candidates", std::move(candidates_json)}};
}

void ScanEvidence::setup(const PointRecord& p) {
  channels_ = p.measured.size();
  for (const auto& e : p.budget) {
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
  for (const auto& s : p.sample_sensitivity)
    names_.push_back(Column{s.parameter, "sample", "", 0, 0, s.value,
                            s.value != 0 ? std::abs(s.value) : std::numeric_limits<double>::infinity(), false, false});
  const auto n = names_.size();
  for (std::size_t j = 0; j < n; ++j)
    if (names_[j].kind == "sample") sample_columns_.push_back(j);
  curvature_of_.assign(n, std::string::npos);
  cross_of_.assign(n, std::string::npos);
  partner_.assign(n, std::string::npos);
  std::size_t e = n;
  for (std::size_t j = 0; j < n; ++j)
    if (names_[j].curved) curvature_of_[j] = e++;
  const auto column_of = [&](const std::string& component) {
    const auto name = component == "reference_white_rel" ? std::string("gain") : component;
    for (std::size_t j = 0; j < n; ++j)
      if (names_[j].name == name) return j;
    return std::string::npos;
  };
  for (const auto& b : p.budget) {
    if (b.cross.empty()) continue;
    const auto j = column_of(b.component), k = column_of(b.cross_with);
    if (j == std::string::npos || k == std::string::npos || j == k) continue;
    partner_[j] = k;
    cross_of_[j] = e++;
  }
  residual_ = e++;
  G_.assign(e, std::vector<double>(e, 0.0));
  const std::size_t bands = std::min<std::size_t>(3, channels_);
  bands_.assign(bands, BandMoments{0, 0, std::vector<double>(n, 0.0), std::vector<double>(n, 0.0),
                                   std::vector<double>(n, 0.0)});
  band_of_.assign(channels_, 0);
  for (std::size_t b = 0; b < bands; ++b)
    for (std::size_t c = b * channels_ / bands; c < (b + 1) * channels_ / bands; ++c) band_of_[c] = b;
}

void ScanEvidence::add(const PointRecord& rec) {
  if (!rec.predicted || rec.budget.empty()) return;
  if (names_.empty()) setup(rec);
  const auto& m = rec.measured;
  const auto& q = *rec.predicted;
  if (m.size() != channels_ || q.size() != channels_) return;
  std::vector<std::vector<double>> columns(names_.size()), curvature(names_.size()), cross(names_.size());
  for (std::size_t j = 0; j < names_.size(); ++j) {
    const auto& col = names_[j];
    std::vector<double> v(channels_, 0.0);
    if (col.kind == "sample") {
      for (const auto& s : rec.sample_sensitivity)
        if (s.parameter == col.name && s.sensitivity.size() == channels_) v = s.sensitivity;
    } else {
      const auto component = col.name == "gain" ? std::string("reference_white_rel") : col.name;
      for (const auto& e : rec.budget)
        if (e.component == component && e.sensitivity.size() == channels_) {
          v = e.sensitivity;
          if (cross_of_[j] != std::string::npos)
            cross[j] = e.cross.size() == channels_ ? e.cross : std::vector<double>(channels_, 0.0);
          if (col.curved) curvature[j] = e.curvature.size() == channels_ ? e.curvature : std::vector<double>(channels_, 0.0);
        }
      if (col.curved && curvature[j].empty()) curvature[j].assign(channels_, 0.0);
      if (cross_of_[j] != std::string::npos && cross[j].empty()) cross[j].assign(channels_, 0.0);
    }
    columns[j] = std::move(v);
  }
  std::vector<double> ext(G_.size(), 0.0);
  for (std::size_t c = 0; c < channels_; ++c) {
    double var = m.std_uncertainty[c] * m.std_uncertainty[c] + q.std_uncertainty[c] * q.std_uncertainty[c];
    for (const auto& e : rec.budget)
      if (e.random && c < e.contribution.size()) var += e.contribution[c] * e.contribution[c];
    const double r = m.values[c] - q.values[c];
    if (!(var > 0)) continue;
    const double w = 1.0 / var;
    for (std::size_t j = 0; j < names_.size(); ++j) {
      ext[j] = columns[j][c];
      if (curvature_of_[j] != std::string::npos) ext[curvature_of_[j]] = curvature[j][c];
      if (cross_of_[j] != std::string::npos) ext[cross_of_[j]] = cross[j][c];
    }
    ext[residual_] = r;
    for (std::size_t i = 0; i < ext.size(); ++i)
      for (std::size_t j = 0; j <= i; ++j) {
        G_[i][j] += w * ext[i] * ext[j];
        G_[j][i] = G_[i][j];
      }
    ++n_;
    const double pv = q.values[c] * w;
    if (pv == 0 || bands_.empty()) continue;
    auto& band = bands_[band_of_[c]];
    band.pp += pv * q.values[c];
    band.pr += pv * r;
    for (std::size_t j = 0; j < names_.size(); ++j) {
      band.ps[j] += pv * columns[j][c];
      if (!curvature[j].empty()) band.pc2[j] += pv * curvature[j][c];
      if (!cross[j].empty()) band.px[j] += pv * cross[j][c];
    }
  }
  for (const auto j : sample_columns_) {
    double margin = std::numeric_limits<double>::infinity();
    for (std::size_t c = 0; c < channels_; ++c)
      if (const double sens = std::abs(columns[j][c]); sens > 0)
        margin = std::min(margin, tolerance_ * std::abs(q.values[c]) / sens);
    margins_.push_back(margin);
  }
  ++points_;
}

ScanEvidence::Fit ScanEvidence::solve(const std::vector<std::size_t>& columns,
                                      const std::vector<std::size_t>& free) const {
  Fit f;
  f.index = columns;
  f.free = free;
  const auto n = columns.size();
  const auto E = G_.size();
  std::vector<double> prior(n, 0.0);  // 1/u² of each column held to its prior, else 0
  for (std::size_t i = 0; i < n; ++i) {
    const bool is_free = std::find(free.begin(), free.end(), columns[i]) != free.end();
    const double pu = names_[columns[i]].prior_u;
    if (!is_free && pu > 0) prior[i] = 1.0 / (pu * pu);
  }
  // The position in the fit of each column's interaction partner (npos: none, or not fitted).
  std::vector<std::size_t> partner(n, std::string::npos);
  for (std::size_t i = 0; i < n; ++i)
    if (const auto k = partner_[columns[i]]; k != std::string::npos)
      if (const auto it = std::find(columns.begin(), columns.end(), k); it != columns.end())
        partner[i] = static_cast<std::size_t>(it - columns.begin());
  // The model in extended columns: f = Σ c1_j θ_j + ½ c2_j θ_j² + c_jk θ_j θ_k; the residual
  // left is res = r − f (coefficients β over the extended columns), and ∂f/∂θ_j (γ_j).
  const auto residual_coefficients = [&](const std::vector<double>& th) {
    std::vector<double> beta(E, 0.0);
    beta[residual_] = 1;
    for (std::size_t i = 0; i < n; ++i) {
      beta[columns[i]] -= th[i];
      if (const auto k = curvature_of_[columns[i]]; k != std::string::npos) beta[k] -= 0.5 * th[i] * th[i];
      if (partner[i] != std::string::npos) beta[cross_of_[columns[i]]] -= th[i] * th[partner[i]];
    }
    return beta;
  };
  const auto form = [&](const std::vector<double>& a, const std::vector<double>& b) {
    double s = 0;
    for (std::size_t i = 0; i < E; ++i) {
      if (a[i] == 0) continue;
      for (std::size_t j = 0; j < E; ++j) s += a[i] * G_[i][j] * b[j];
    }
    return s;
  };
  const auto objective = [&](const std::vector<double>& th) {
    const auto beta = residual_coefficients(th);
    double chi2 = form(beta, beta);
    for (std::size_t i = 0; i < n; ++i) chi2 += prior[i] * th[i] * th[i];
    return chi2;
  };
  // A rectangular (or triangular) input held to its data sheet cannot lie beyond ±its limit:
  // a hard bound beside the normal penalty (projected Gauss–Newton with an active set).
  std::vector<double> bound(n, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    if (prior[i] > 0 && names_[columns[i]].bounded) bound[i] = names_[columns[i]].limit;
  std::vector<int> at_bound(n, 0);  // −1, +1: held at −/+bound
  std::vector<double> theta(n, 0.0);
  std::vector<std::vector<double>> inv;
  double chi2 = objective(theta);
  bool solved = false;
  // The normal equations at theta: M (at-bound rows made identity) and the descent direction.
  const auto normal_equations = [&](std::vector<std::vector<double>>& M, std::vector<double>& rhs) {
    const auto beta = residual_coefficients(theta);
    std::vector<std::vector<double>> gamma(n, std::vector<double>(E, 0.0));
    for (std::size_t i = 0; i < n; ++i) {
      gamma[i][columns[i]] = 1;
      if (const auto k = curvature_of_[columns[i]]; k != std::string::npos) gamma[i][k] = theta[i];
    }
    for (std::size_t i = 0; i < n; ++i)
      if (partner[i] != std::string::npos) {
        gamma[i][cross_of_[columns[i]]] = theta[partner[i]];
        gamma[partner[i]][cross_of_[columns[i]]] = theta[i];
      }
    M.assign(n, std::vector<double>(n, 0.0));
    rhs.assign(n, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      rhs[i] = form(gamma[i], beta) - prior[i] * theta[i];
      for (std::size_t j = 0; j <= i; ++j) M[i][j] = M[j][i] = form(gamma[i], gamma[j]);
      M[i][i] += prior[i];
    }
  };
  for (int iter = 0; iter < 40; ++iter) {
    std::vector<std::vector<double>> M;
    std::vector<double> rhs;
    normal_equations(M, rhs);
    for (std::size_t i = 0; i < n; ++i)
      if (at_bound[i] != 0) {
        for (std::size_t j = 0; j < n; ++j) M[i][j] = M[j][i] = 0;
        M[i][i] = 1;
      }
    const auto raw_rhs = rhs;
    for (std::size_t i = 0; i < n; ++i)
      if (at_bound[i] != 0) rhs[i] = 0;
    if (!cholesky_inverse(M, inv)) break;
    solved = true;
    std::vector<double> step(n, 0.0);
    double size = 0;
    for (std::size_t i = 0; i < n; ++i) {
      for (std::size_t j = 0; j < n; ++j) step[i] += inv[i][j] * rhs[j];
      size = std::max(size, std::abs(step[i]));
    }
    // Halve the step until χ² does not rise (the quadratic terms can overshoot); clamp to
    // the bounds, and hold what reaches one there.
    double t = 1;
    std::vector<double> next(n);
    std::vector<int> hits(n, 0);
    bool moved = false;
    for (int h = 0; h < 20; ++h, t /= 2) {
      for (std::size_t i = 0; i < n; ++i) {
        next[i] = theta[i] + t * step[i];
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
      if (at_bound[i] != 0 && raw_rhs[i] * at_bound[i] < 0) {
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
  for (std::size_t i = 0; i < n; ++i) f.u[i] = at_bound[i] != 0 ? 0.0 : std::sqrt(std::max(0.0, inv[i][i]));
  f.chi2 = chi2;
  return f;
}

bool ScanEvidence::is_candidate(std::size_t j) const {
  return names_[j].kind == "sample" || names_[j].unit == "deg" || names_[j].name == "gain";
}

std::size_t ScanEvidence::candidates() const noexcept {
  std::size_t n = 0;
  for (std::size_t j = 0; j < names_.size(); ++j) n += is_candidate(j) ? 1 : 0;
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
  return VerdictCause{col.kind, col.name, col.nominal + c.fit.theta[pos], c.fit.u[pos] * scale, col.nominal};
}

// The per-band mean relative difference left by `fit` (its instrument inputs removed), with
// its uncertainty: the points' own and the instrument's systematic inputs' (posterior).
ScanEvidence::BandResult ScanEvidence::band_decision(const Fit& fit) const {
  BandResult out;
  const double scale = std::sqrt(std::max(1.0, fit.chi2 / dof(fit.free.size())));
  const auto theta_of = [&](std::size_t column) {
    const auto it = std::find(fit.index.begin(), fit.index.end(), column);
    return it == fit.index.end() ? 0.0 : fit.theta[static_cast<std::size_t>(it - fit.index.begin())];
  };
  for (const auto& band : bands_) {
    // Σ p·r'/v and Σ p·∂r'/∂θ_i /v of the residual r' with the fitted instrument inputs'
    // effect removed (r' = r − s θ − ½ c₂ θ² − c×θ θ_partner), from the band's moments.
    const double s0 = band.pp;
    double s1 = band.pr;
    std::vector<double> sj(fit.index.size(), 0.0);
    for (std::size_t i = 0; i < fit.index.size(); ++i) {
      const auto j = fit.index[i];
      if (names_[j].kind == "sample") continue;
      const double th = fit.theta[i];
      const double other = cross_of_[j] != std::string::npos ? theta_of(partner_[j]) : 0.0;
      s1 -= band.ps[j] * th + 0.5 * band.pc2[j] * th * th + band.px[j] * th * other;
      sj[i] = band.ps[j] + band.pc2[j] * th + band.px[j] * other;
    }
    if (!(s0 > 0)) continue;
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
  }
  return out;
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

// H0 (the instrument's inputs held to their data sheets) against one candidate cause at a
// time; the best, if it stands out by kSignificant and no other is within kTie of it, is
// named, and its decision is the scan's. Otherwise the scan is judged per band under H0.
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
  // Too few points for a cause: only the per-band test.
  const auto cands = points_ < needed ? std::vector<Fitted>{} : fit_candidates(instrument, sample);
  for (const auto& c : cands) v.candidates.push_back({cause_of(c), h0.chi2 - c.fit.chi2});
  // Evidence: a candidate that lowers χ² by kSignificant. (H0 holds each rectangular input
  // within its stated limit, so an arm truly beyond it cannot hide in H0's prior.)
  const bool significant = !cands.empty() && std::isfinite(cands.front().fit.chi2) &&
                           h0.chi2 - cands.front().fit.chi2 > kSignificant;
  if (!significant) {
    const auto b = band_decision(h0);
    v.decision = decision_text(b.decision);
    v.chi2_per_dof = h0.chi2 / dof(0);
    v.summary = fmt::format("{} over {} points: the worst band differs by {:+.2f} ± {:.2f} % (tolerance {}); {} (χ²/dof {:.3g})",
                            b.decision == Decision::agrees ? "agrees" : b.decision == Decision::out_of_tolerance ? "out of tolerance" : "undecided",
                            points_, 100 * b.worst_rel, 100 * b.worst_u, tolerance_text(),
                            points_ < needed
                                ? fmt::format("the cause is undetermined until {} points are in", needed)
                                : std::string("no candidate cause stands out"),
                            v.chi2_per_dof);
    return v;
  }
  const auto& best = cands.front();
  v.delta_chi2_next = cands.size() > 1 ? cands[1].fit.chi2 - best.fit.chi2 : 0;
  v.chi2_per_dof = best.fit.chi2 / dof(1);
  std::string text;
  v.decision = decide_for(best, text);
  std::vector<const Fitted*> tied;
  for (std::size_t i = 1; i < cands.size(); ++i)
    if (cands[i].fit.chi2 - best.fit.chi2 < kTie) tied.push_back(&cands[i]);
  if (!tied.empty()) {
    // The points cannot tell these apart: no cause is named.
    std::string names = describe(cause_of(best));
    bool same = true;
    for (const auto* t : tied) {
      std::string other;
      same = same && decide_for(*t, other) == v.decision;
      v.alike.push_back(cause_of(*t));
      names += " or " + describe(v.alike.back());
    }
    v.alike.insert(v.alike.begin(), cause_of(best));
    if (!same) v.decision = "undecided";
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
