// The scan's evidence, point by point: the Gram matrix of the columns' sensitivities and
// residuals, the per-band and per-region moments, the scatter terms and the per-point margins
// (see verdict.hpp).
#include "gonio/daemon/instrument/verdict.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <Eigen/Core>
#include <fmt/format.h>

#include "gonio/daemon/instrument/divergence.hpp"
#include "instrument/evidence_matrix.hpp"

namespace gonio::daemon {
using evidence::npos;
using evidence::view;
namespace {

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
}  // namespace

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

}  // namespace gonio::daemon
