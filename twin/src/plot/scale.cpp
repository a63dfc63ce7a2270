// Axis scales and tick marks for the line plots: pure functions of the axis settings and
// the data (scale.hpp), no drawing.
#include "gonio/twin/detail/plot/scale.hpp"

#include <algorithm>
#include <limits>

#include <fmt/format.h>

namespace gonio::twin::plot {

double nice_step(double x) {
  const double e = std::floor(std::log10(x));
  const double f = x / std::pow(10.0, e);
  const double nf = f < 1.5 ? 1 : f < 3 ? 2 : f < 7 ? 5 : 10;
  return nf * std::pow(10.0, e);
}

std::string format_tick(double v, double step) {
  const int decimals = std::max(0, -static_cast<int>(std::floor(std::log10(step) + 1e-9)));
  if (std::abs(v) < step * 1e-9) v = 0;  // no "-0"
  return fmt::format("{:.{}f}", v, decimals);
}

std::vector<Tick> ticks(const Scale& s, double length_px) {
  std::vector<Tick> out;
  if (!s.log) {
    const int target = std::clamp(static_cast<int>(length_px / 70), 3, 10);
    const double step = nice_step((s.hi - s.lo) / target);
    for (double k = std::ceil(s.lo / step - 1e-9); k * step <= s.hi + step * 1e-9; k += 1) {
      const double v = k * step;
      out.push_back({v, {format_tick(v, step), ""}, true});
    }
    return out;
  }
  const double d0 = std::floor(std::log10(s.lo)), d1 = std::ceil(std::log10(s.hi));
  const double decades = std::log10(s.hi / s.lo);
  const int every = std::max(1, static_cast<int>(std::ceil((d1 - d0) / std::max(2.0, length_px / 45))));
  for (double d = d0; d <= d1; d += 1) {
    for (int m = 1; m <= 9; ++m) {
      const double v = m * std::pow(10.0, d);
      if (v < s.lo * (1 - 1e-9) || v > s.hi * (1 + 1e-9)) continue;
      if (decades < 1.5) {  // few decades: plain numbers at 1, 2, 5
        const bool labelled = m == 1 || m == 2 || m == 5;
        const double step = std::pow(10.0, d);
        out.push_back({v, {labelled ? format_tick(v, step) : "", ""}, labelled});
      } else if (m == 1) {
        const bool labelled = static_cast<long long>(d - d0) % every == 0;
        out.push_back({v, {labelled ? "10" : "", labelled ? fmt::format("{:g}", d) : ""}, true});
      } else if (decades <= 6) {
        out.push_back({v, {}, false});  // unlabelled minor tick
      }
    }
  }
  return out;
}

std::pair<double, double> auto_range(const Axis& axis, const std::vector<Series>& series,
                                     bool is_y) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  const auto take = [&](double v) {
    if (!std::isfinite(v) || (axis.log && v <= 0)) return;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  };
  for (const auto& s : series) {
    const auto& v = is_y ? s.y : s.x;
    for (std::size_t i = 0; i < v.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      take(v[i]);
      if (is_y && !s.sigma.empty()) {
        take(v[i] + s.sigma[i]);
        if (!axis.log || v[i] - s.sigma[i] > v[i] * 0.1) take(v[i] - s.sigma[i]);
      }
    }
  }
  if (!(lo <= hi)) return axis.log ? std::pair{1.0, 10.0} : std::pair{0.0, 1.0};
  if (axis.log) {
    double l = std::log10(lo), h = std::log10(hi);
    if (h - l < 1e-9) {
      l -= 0.5;
      h += 0.5;
    }
    const double pad = 0.04 * (h - l);
    return {std::pow(10.0, l - pad), std::pow(10.0, h + pad)};
  }
  if (hi - lo < 1e-12 * std::max(1.0, std::abs(hi))) {
    const double d = std::max(1.0, std::abs(hi) * 0.1);
    return {lo - d, hi + d};
  }
  const double pad = 0.04 * (hi - lo);
  return {lo - pad, hi + pad};
}

Scale make_scale(const Axis& axis, const std::vector<Series>& series, bool is_y) {
  auto [lo, hi] = auto_range(axis, series, is_y);
  if (axis.min) lo = *axis.min;
  if (axis.max) hi = *axis.max;
  if (!(hi > lo)) {  // one bound given and the data beyond it
    if (axis.log) {
      if (axis.min) hi = lo * 10;
      else lo = hi / 10;
    } else {
      if (axis.min) hi = lo + 1;
      else lo = hi - 1;
    }
  }
  Scale s;
  s.lo = lo;
  s.hi = hi;
  s.log = axis.log;
  return s;
}

std::string axis_title(const Axis& a) {
  return a.unit.empty() ? a.label : fmt::format("{} ({})", a.label, a.unit);
}

}  // namespace gonio::twin::plot
