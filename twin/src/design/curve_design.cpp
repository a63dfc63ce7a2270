// CurveDesign — refine the measured curves where interpolation is least certain.
//
// Along each curve (the candidates that share an incidence and azimuths, by receiving
// angle) the delivered curve is the local cubic through the two measured neighbours on each
// side (fewer near an end), in log β (in β where a value is not positive): a lobe's flanks
// and tails are close to exponential, so far fewer points carry them to a relative
// tolerance. Its error at an unmeasured candidate is estimated by how far it lies from the
// quintic through one more neighbour on each side and from the cubics on the stencils
// shifted by one to either side, whichever differs most: the classic a-posteriori estimate
// of adaptive quadrature and curve sampling, the difference between interpolants standing
// in for the delivered one's error (de Boor, A Practical Guide to Splines, 2001, ch. II–IV),
// with the shifted stencils guarding against two interpolants agreeing by chance where the
// curve turns (a lobe meeting its diffuse floor). The readings' own noise is no interpolation error: the part of
// the gap within k·u of the interpolated uncertainty is not counted.
//
// The estimate sees only what the measured points hint at: a feature narrower than the seed
// spacing between two seeds would be missed, which is why the specular and the
// retro-reflection directions, where a sample's narrow peaks are, are always seeds.
#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "gonio/proto/error.hpp"
#include "gonio/twin/design.hpp"

namespace gonio::twin {

namespace {

constexpr double kUnknown = 1e300;

long key(double v) { return std::lround(v * 1e6); }

// The Lagrange weights of the interpolant through the nodes xs at x (Σ w_i y_i).
std::vector<double> lagrange_weights(const std::vector<double>& xs, double x) {
  std::vector<double> w(xs.size(), 1.0);
  for (std::size_t i = 0; i < xs.size(); ++i)
    for (std::size_t j = 0; j < xs.size(); ++j)
      if (j != i) w[i] *= (x - xs[j]) / (xs[i] - xs[j]);
  return w;
}

}  // namespace

void CurveDesignOptions::validate() const {
  if (!(tolerance > 0 && tolerance <= 1)) throw Error::out_of_range("tolerance", tolerance, 0, 1);
  timing.validate();
  if (!(seed_spacing_deg >= 0.1 && seed_spacing_deg <= 180))
    throw Error::out_of_range("seed_spacing_deg", seed_spacing_deg, 0.1, 180, "°");
  if (!(coverage_k >= 0 && coverage_k <= 10)) throw Error::out_of_range("coverage_k", coverage_k, 0, 10);
  if (!(safety >= 1 && safety <= 10)) throw Error::out_of_range("safety", safety, 1, 10);
  if (!(floor >= 0 && floor <= 1)) throw Error::out_of_range("floor", floor, 0, 1);
}

CurveDesign::CurveDesign(std::vector<Geometry> candidates, CurveDesignOptions options)
    : Design(std::move(candidates), 1), options_(std::move(options)) {
  options_.validate();
  std::map<std::tuple<long, long, long>, std::size_t> index;
  for (std::size_t c = 0; c < candidates_.size(); ++c) {
    const auto& g = candidates_[c];
    const auto k = std::make_tuple(key(g.theta_i), key(g.phi_i), key(g.phi_r));
    const auto [it, fresh] = index.emplace(k, curves_.size());
    if (fresh) curves_.emplace_back();
    curves_[it->second].members.push_back(c);
  }
  curve_of_.assign(candidates_.size(), 0);
  position_.assign(candidates_.size(), 0);
  for (std::size_t k = 0; k < curves_.size(); ++k) {
    auto& m = curves_[k].members;
    std::stable_sort(m.begin(), m.end(), [&](std::size_t a, std::size_t b) {
      return candidates_[a].theta_r < candidates_[b].theta_r;
    });
    for (std::size_t i = 0; i < m.size(); ++i) {
      curve_of_[m[i]] = k;
      position_[m[i]] = i;
    }
  }
  points_.resize(candidates_.size());
  error_.assign(candidates_.size(), kUnknown);
}

std::vector<std::size_t> CurveDesign::seeds() const {
  std::vector<std::size_t> out;
  bool forward = true;
  for (const auto& curve : curves_) {
    const auto& m = curve.members;
    std::vector<bool> pick(m.size(), false);
    pick.front() = pick.back() = true;
    // The specular and retro-reflection directions: the nearest candidate to each.
    const double ti = candidates_[m.front()].theta_i;
    for (const double target : {ti, -ti}) {
      std::size_t best = 0;
      for (std::size_t i = 1; i < m.size(); ++i)
        if (std::abs(candidates_[m[i]].theta_r - target) < std::abs(candidates_[m[best]].theta_r - target)) best = i;
      if (std::abs(candidates_[m[best]].theta_r - target) <= options_.seed_spacing_deg / 2) pick[best] = true;
    }
    // Then no gap wider than the seed spacing: the farthest member still within it.
    std::size_t last = 0;
    for (std::size_t i = 1; i < m.size(); ++i) {
      if (pick[i]) {
        last = i;
        continue;
      }
      const bool next_too_far = i + 1 < m.size() &&
                                candidates_[m[i + 1]].theta_r - candidates_[m[last]].theta_r > options_.seed_spacing_deg + 1e-9;
      if (next_too_far) {
        pick[i] = true;
        last = i;
      }
    }
    // Boustrophedon: each curve swept from the end the arm is nearer.
    std::vector<std::size_t> mine;
    for (std::size_t i = 0; i < m.size(); ++i)
      if (pick[i]) mine.push_back(m[i]);
    if (!forward) std::reverse(mine.begin(), mine.end());
    forward = !forward;
    out.insert(out.end(), mine.begin(), mine.end());
  }
  return out;
}

void CurveDesign::add(std::size_t c, const MeasuredPoint& p) {
  if (p.beta.empty() || p.beta.size() != p.u.size())
    throw Error::invalid("point", "needs β and u on the same channels");
  for (const auto& q : points_)
    if (!q.beta.empty() && q.beta.size() != p.beta.size())
      throw Error::invalid("point", "has another number of channels than the points before");
  mark(c);
  points_[c] = p;
  points_[c].geometry = candidates_[c];
}

std::optional<CurveDesign::Estimate> CurveDesign::estimate(std::size_t c) const {
  const auto& m = curves_[curve_of_[c]].members;
  const auto i = position_[c];
  std::vector<std::size_t> known;  // positions of the measured members
  for (std::size_t j = 0; j < m.size(); ++j)
    if (!points_[m[j]].beta.empty()) known.push_back(j);
  const auto k = static_cast<std::size_t>(std::upper_bound(known.begin(), known.end(), i) - known.begin());
  if (k == 0 || k == known.size()) return std::nullopt;  // outside the measured range
  // Delivered: through two measured neighbours on each side (fewer near an end); its error:
  // against the interpolant through one more on each side.
  const auto span = [&](std::size_t w) {
    std::vector<std::size_t> nodes;
    for (std::size_t j = k >= w ? k - w : 0; j < std::min(known.size(), k + w); ++j) nodes.push_back(m[known[j]]);
    return nodes;
  };
  const auto inner = span(2), outer = span(3);
  // The same order on shifted stencils (three before and one after, one before and three
  // after): where the curve changes character inside a gap, stencils of one order disagree
  // even when two orders happen to agree.
  const auto shifted = [&](std::size_t before, std::size_t after) {
    std::vector<std::size_t> nodes;
    if (k < before || k + after > known.size()) return nodes;
    for (std::size_t j = k - before; j < k + after; ++j) nodes.push_back(m[known[j]]);
    return nodes;
  };
  const auto left = shifted(3, 1), right = shifted(1, 3);
  const double x = candidates_[c].theta_r;
  const auto& a = points_[m[known[k - 1]]];
  Estimate out;
  out.error = outer.size() > inner.size() ? 0 : kUnknown;
  // Per candidate node, its weight in the delivered interpolant and in each comparison.
  const auto weights = [&](const std::vector<std::size_t>& nodes) {
    std::vector<double> xs;
    for (const auto n : nodes) xs.push_back(candidates_[n].theta_r);
    const auto w = lagrange_weights(xs, x);
    std::map<std::size_t, double> by_node;
    for (std::size_t j = 0; j < nodes.size(); ++j) by_node[nodes[j]] = w[j];
    return by_node;
  };
  const auto w_inner = weights(inner);
  std::vector<std::map<std::size_t, double>> comparisons{weights(outer)};
  if (inner.size() == 4) {
    if (!left.empty()) comparisons.push_back(weights(left));
    if (!right.empty()) comparisons.push_back(weights(right));
  }
  for (std::size_t ch = 0; ch < a.beta.size(); ++ch) {
    bool positive = true;
    for (const auto n : outer) positive = positive && points_[n].beta[ch] > 0;
    double peak = 0;  // of the curve's measured values in this channel
    for (const auto& kn : known) peak = std::max(peak, points_[m[kn]].beta[ch]);
    // In logarithms where the values allow (relative errors directly, u/β as the noise).
    const auto y = [&](std::size_t n) { return positive ? std::log(points_[n].beta[ch]) : points_[n].beta[ch]; };
    const auto sd = [&](std::size_t n) { return positive ? points_[n].u[ch] / points_[n].beta[ch] : points_[n].u[ch]; };
    double delivered = 0;
    for (const auto& [n, w] : w_inner) delivered += w * y(n);
    out.value.push_back(positive ? std::exp(delivered) : delivered);
    if (out.error >= kUnknown) continue;
    // Each comparison's difference from the delivered value, less k times that difference's
    // own standard deviation from the readings' noise (exact: both are linear in the readings).
    double gap = 0;
    for (const auto& wc : comparisons) {
      auto diff_w = wc;
      for (const auto& [n, w] : w_inner) diff_w[n] -= w;
      double diff = 0, var = 0;
      for (const auto& [n, w] : diff_w) {
        diff += w * y(n);
        var += w * w * sd(n) * sd(n);
      }
      gap = std::max(gap, options_.safety * std::abs(diff) - options_.coverage_k * std::sqrt(var));
    }
    // Relative to the value, but not below floor × the curve's peak: a tail a thousand
    // times darker than the lobe need not be known to 1 % of itself.
    const double value = out.value.back();
    const double scale = std::max({std::abs(value), options_.floor * peak, 1e-300});
    out.error = std::max(out.error, positive ? gap * value / scale : gap / scale);
  }
  return out;
}

std::vector<double> CurveDesign::interpolate(std::size_t c) const {
  if (!points_[c].beta.empty()) return points_[c].beta;
  const auto e = estimate(c);
  return e ? e->value : std::vector<double>{};
}

void CurveDesign::update() {
  max_error_ = 0;
  for (std::size_t c = 0; c < candidates_.size(); ++c) {
    if (!points_[c].beta.empty()) {
      error_[c] = 0;
      continue;
    }
    const auto e = estimate(c);
    error_[c] = e ? e->error : kUnknown;
    max_error_ = std::max(max_error_, error_[c]);
  }
}

std::optional<std::size_t> CurveDesign::next(const std::vector<std::size_t>& pending, const Geometry& arms) const {
  // In every gap between filled (measured or pending) members, the member with the largest
  // estimated error, if it is above the tolerance; of these, the nearest in instrument time.
  const auto filled = [&](std::size_t c) {
    return !points_[c].beta.empty() || std::find(pending.begin(), pending.end(), c) != pending.end();
  };
  std::optional<std::size_t> best;
  double best_s = 1e300;
  for (const auto& curve : curves_) {
    const auto& m = curve.members;
    std::vector<std::size_t> gap;
    const auto close_gap = [&] {
      if (gap.empty()) return;
      // The largest estimate; among equal ones (unknown), the middle of the gap.
      std::size_t worst = gap[gap.size() / 2];
      for (const auto c : gap)
        if (error_[c] > error_[worst] * (1 + 1e-9)) worst = c;
      gap.clear();
      if (error_[worst] <= options_.tolerance || !movable(arms, worst)) return;
      const double s = options_.timing.point_s(arms, candidates_[worst]);
      if (s < best_s) {
        best_s = s;
        best = worst;
      }
    };
    for (const auto c : m) {
      if (filled(c)) close_gap();
      else gap.push_back(c);
    }
    close_gap();
  }
  return best;
}

bool CurveDesign::target_reached() const { return max_error_ <= options_.tolerance; }

DesignStatus CurveDesign::status() const {
  DesignStatus s;
  s.mode = AdaptiveMode::curve;
  s.state = target_reached() ? DesignState::target_reached : DesignState::running;
  s.points_used = measured_.size();
  if (max_error_ < kUnknown) s.estimated_error = max_error_;
  return s;
}

}  // namespace gonio::twin
