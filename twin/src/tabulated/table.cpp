// BsdfTable and SpecularTable: validated angular tables with multilinear interpolation.
//
// The table is the common currency of the file formats and of the twin's virtual
// measurements, so it stores exactly what SSDD can express (three parametrizations, two
// reductions, any wavelength list) and nothing that a file could not carry.
#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/tabulated.hpp"
#include "tabulated/common.hpp"

namespace gonio::twin {
namespace {

constexpr std::size_t kMaxTableChannels = 4096;

// Position on an axis: value = (1 − t)·node[i0] + t·node[i1].
struct AxisPos {
  std::size_t i0 = 0, i1 = 0;
  double t = 0;
};

AxisPos clamp_pos(const std::vector<double>& n, double x) noexcept {
  if (n.size() < 2 || !(x > n.front())) return {0, 0, 0};
  if (x >= n.back()) return {n.size() - 1, n.size() - 1, 0};
  const auto it = std::upper_bound(n.begin(), n.end(), x);
  const auto i = static_cast<std::size_t>(it - n.begin());
  return {i - 1, i, (x - n[i - 1]) / (n[i] - n[i - 1])};
}

double wrap(double x, double period) noexcept {
  double r = std::fmod(x, period);
  if (r < 0) r += period;
  return r >= period ? 0 : r;
}

// Azimuth axis of the given period: mirrored about 0 and period/2 when `mirror`, else
// periodic with a wrap-around cell between the last node and the first node + period.
AxisPos azimuth_pos(const std::vector<double>& n, double x, double period, bool mirror) noexcept {
  if (n.size() < 2) return {0, 0, 0};
  if (!std::isfinite(x)) x = 0;
  x = wrap(x, period);
  if (mirror) {
    if (x > period / 2) x = period - x;
    return clamp_pos(n, x);
  }
  const double first = n.front(), last = n.back();
  if (x >= first && x <= last) return clamp_pos(n, x);
  const double span = first + period - last;
  if (span <= 1e-9) return clamp_pos(n, x);
  const double xx = x < first ? x + period : x;
  return {n.size() - 1, 0, std::clamp((xx - last) / span, 0.0, 1.0)};
}

double p3_period(TableParam p, const TableReduction& r) noexcept {
  return p == TableParam::half_difference && r.reciprocal ? 180.0 : 360.0;
}

void check_axis(const std::vector<double>& a, const std::string& field, double lo, double hi,
                bool allow_empty) {
  if (a.empty()) {
    if (allow_empty) return;
    throw Error::invalid(field, "needs at least one node");
  }
  if (a.size() > BsdfTable::kMaxNodes)
    throw Error(Errc::out_of_range,
                fmt::format("{} has {} nodes, more than {}", field, a.size(), BsdfTable::kMaxNodes),
                field);
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto f = fmt::format("{}[{}]", field, i);
    if (!std::isfinite(a[i]) || a[i] < lo || a[i] > hi)
      throw Error::out_of_range(f, a[i], lo, hi, " deg");
    if (i > 0 && !(a[i] > a[i - 1]))
      throw Error::invalid(f, fmt::format("{:g} does not increase on {:g}", a[i], a[i - 1]));
  }
}

void check_wavelengths(const std::vector<double>& nm, const std::string& field) {
  if (nm.size() > kMaxTableChannels)
    throw Error(Errc::out_of_range,
                fmt::format("{} has {} entries, more than {}", field, nm.size(), kMaxTableChannels),
                field);
  for (std::size_t i = 0; i < nm.size(); ++i) {
    const auto f = fmt::format("{}[{}]", field, i);
    if (!std::isfinite(nm[i]) || nm[i] <= 0 || nm[i] > 1e5)
      throw Error::out_of_range(f, nm[i], 0, 1e5, " nm");
    if (i > 0 && !(nm[i] > nm[i - 1]))
      throw Error::invalid(f, fmt::format("{:g} nm does not increase on {:g} nm", nm[i], nm[i - 1]));
  }
}

void check_values(const std::vector<double>& v, const std::string& field, double hi) {
  for (std::size_t i = 0; i < v.size(); ++i)
    if (!std::isfinite(v[i]) || v[i] < 0 || v[i] > hi)
      throw Error::out_of_range(fmt::format("{}[{}]", field, i), v[i], 0, hi);
}

// n0·n1·n2·n3·channels without overflow; throws when beyond BsdfTable::kMaxValues.
std::size_t checked_size(std::initializer_list<std::size_t> dims, const std::string& field) {
  std::size_t total = 1;
  for (const auto d : dims) {
    if (d != 0 && total > BsdfTable::kMaxValues / d)
      throw Error(Errc::out_of_range,
                  fmt::format("{} would hold more than {} values", field, BsdfTable::kMaxValues),
                  field);
    total *= d;
  }
  if (total > BsdfTable::kMaxValues)
    throw Error(Errc::out_of_range,
                fmt::format("{} would hold more than {} values", field, BsdfTable::kMaxValues), field);
  return total;
}

// Per target wavelength: the two source channels and the weight of the second.
struct SpectralMap {
  std::size_t j0, j1;
  double w;
};

std::vector<SpectralMap> spectral_map(const std::vector<double>& from, const std::vector<double>& to) {
  std::vector<SpectralMap> m;
  m.reserve(to.size());
  for (const double x : to) {
    if (from.size() < 2 || x <= from.front()) {
      m.push_back({0, 0, 0});
    } else if (x >= from.back()) {
      m.push_back({from.size() - 1, from.size() - 1, 0});
    } else {
      const auto it = std::upper_bound(from.begin(), from.end(), x);
      const auto i = static_cast<std::size_t>(it - from.begin());
      m.push_back({i - 1, i, (x - from[i - 1]) / (from[i] - from[i - 1])});
    }
  }
  return m;
}

// Re-expresses channel blocks of `values` (each `from_ch` long) on the target channels.
std::vector<double> resample_channels(const std::vector<double>& values,
                                      const std::vector<double>& from_nm,
                                      const std::vector<double>& to_nm) {
  const std::size_t from_ch = from_nm.empty() ? 1 : from_nm.size();
  const std::size_t to_ch = to_nm.empty() ? 1 : to_nm.size();
  const std::size_t n = values.size() / from_ch;
  std::vector<double> out(n * to_ch);
  if (to_nm.empty()) {  // grey: channel mean
    for (std::size_t k = 0; k < n; ++k) {
      double s = 0;
      for (std::size_t c = 0; c < from_ch; ++c) s += values[k * from_ch + c];
      out[k] = s / static_cast<double>(from_ch);
    }
    return out;
  }
  if (from_nm.empty()) {  // grey source: the same value everywhere
    for (std::size_t k = 0; k < n; ++k)
      std::fill_n(out.begin() + static_cast<std::ptrdiff_t>(k * to_ch), to_ch, values[k]);
    return out;
  }
  const auto map = spectral_map(from_nm, to_nm);
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t c = 0; c < to_ch; ++c) {
      const auto& m = map[c];
      out[k * to_ch + c] =
          (1 - m.w) * values[k * from_ch + m.j0] + m.w * values[k * from_ch + m.j1];
    }
  return out;
}

std::vector<double> weigh_channels(const std::vector<double>& values, std::size_t ch,
                                   std::span<const double> w, const std::string& field) {
  if (w.size() != ch)
    throw Error::invalid(field, fmt::format("has {} weights for {} channels", w.size(), ch));
  for (std::size_t c = 0; c < ch; ++c)
    if (!std::isfinite(w[c]) || w[c] < 0)
      throw Error::invalid(fmt::format("{}[{}]", field, c), "must be finite and >= 0");
  const std::size_t n = values.size() / ch;
  std::vector<double> out(n, 0.0);
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t c = 0; c < ch; ++c) out[k] += w[c] * values[k * ch + c];
  return out;
}

}  // namespace

// ---- BsdfTable ----------------------------------------------------------------------------------

std::size_t BsdfTable::check_axes(TableParam param, const Axes& axes, TableReduction reduction,
                                  std::size_t channels) {
  if (reduction.reciprocal && param != TableParam::half_difference)
    throw Error::invalid("table.reduction",
                         "reciprocity reduction needs the half_difference parametrization");
  const double radial_max = param == TableParam::specular ? 180.0 : 90.0;
  const double period = p3_period(param, reduction);
  check_axis(axes.p0, "table.p0", 0, 90, false);
  check_axis(axes.p1, "table.p1", 0, 360, true);
  check_axis(axes.p2, "table.p2", 0, radial_max, false);
  check_axis(axes.p3, "table.p3", 0, reduction.bilateral ? period / 2 : period, false);
  return checked_size({axes.p0.size(), std::max<std::size_t>(1, axes.p1.size()), axes.p2.size(),
                       axes.p3.size(), channels},
                      "table");
}

BsdfTable::BsdfTable(TableParam param, Axes axes, std::vector<double> wavelengths_nm,
                     std::vector<double> values, TableReduction reduction)
    : param_(param), axes_(std::move(axes)), nm_(std::move(wavelengths_nm)),
      values_(std::move(values)), reduction_(reduction) {
  check_wavelengths(nm_, "table.wavelengths");
  const std::size_t total = check_axes(param_, axes_, reduction_, channels());
  if (values_.size() != total)
    throw Error::invalid("table.values", fmt::format("has {} entries, the axes need {}",
                                                     values_.size(), total));
  check_values(values_, "table.values", kMaxF);
}

const std::vector<double>& BsdfTable::axis(int k) const {
  switch (k) {
    case 0: return axes_.p0;
    case 1: return axes_.p1;
    case 2: return axes_.p2;
    case 3: return axes_.p3;
    default: throw Error::out_of_range("axis", k, 0, 3);
  }
}

std::size_t BsdfTable::nodes(int k) const noexcept {
  switch (k) {
    case 0: return axes_.p0.size();
    case 1: return std::max<std::size_t>(1, axes_.p1.size());
    case 2: return axes_.p2.size();
    case 3: return axes_.p3.size();
    default: return 0;
  }
}

std::size_t BsdfTable::index(std::size_t i0, std::size_t i1, std::size_t i2,
                             std::size_t i3) const noexcept {
  return ((i3 * nodes(2) + i2) * nodes(1) + i1) * nodes(0) + i0;
}

std::array<double, 4> BsdfTable::coords(const Vec3& wi, const Vec3& wo) const noexcept {
  std::array<double, 4> p{};
  switch (param_) {
    case TableParam::spherical: {
      const double phi_i = tab::incidence_azimuth_deg(wi);
      p[0] = tab::polar_deg(wi);
      p[2] = tab::polar_deg(wo);
      const double phi_o = tab::azimuth_deg(wo);
      if (isotropic()) {
        p[3] = phi_o - phi_i;
      } else {
        p[1] = phi_i;
        p[3] = phi_o;
      }
      break;
    }
    case TableParam::specular: {
      p[0] = tab::polar_deg(wi);
      if (!isotropic()) p[1] = tab::incidence_azimuth_deg(wi);
      const auto frame = tab::MirrorFrame::of(wi);
      double a = 0;
      frame.angles(wo, p[2], a);
      p[3] = a * kRadToDeg;
      break;
    }
    case TableParam::half_difference: {
      double hd[4];
      tab::half_difference(wi, wo, hd);
      p = {hd[0], hd[1], hd[2], hd[3]};
      break;
    }
  }
  return p;
}

void BsdfTable::interpolate(const std::array<double, 4>& p, std::span<double> out) const noexcept {
  std::fill(out.begin(), out.end(), 0.0);
  if (values_.empty()) return;
  const double period = p3_period(param_, reduction_);
  const AxisPos a0 = clamp_pos(axes_.p0, p[0]);
  const AxisPos a1 = isotropic() ? AxisPos{} : azimuth_pos(axes_.p1, p[1], 360.0, false);
  const AxisPos a2 = clamp_pos(axes_.p2, p[2]);
  const AxisPos a3 = azimuth_pos(axes_.p3, p[3], period, reduction_.bilateral);
  const std::size_t ch = channels();
  const std::size_t n = std::min(ch, out.size());
  // Only the bracketing nodes with non-zero weight (an axis at a node or held constant has
  // one), visited in the order of the 16-corner sum so that the result does not change.
  const std::size_t stride[4] = {ch, ch * nodes(0), ch * nodes(0) * nodes(1),
                                 ch * nodes(0) * nodes(1) * nodes(2)};
  const AxisPos* pos[4] = {&a0, &a1, &a2, &a3};
  std::size_t off[4][2];
  double wt[4][2];
  int cnt[4];
  for (int k = 0; k < 4; ++k) {
    const AxisPos& ap = *pos[k];
    cnt[k] = 0;
    if (1 - ap.t != 0) {
      off[k][cnt[k]] = ap.i0 * stride[k];
      wt[k][cnt[k]++] = 1 - ap.t;
    }
    if (ap.t != 0) {
      off[k][cnt[k]] = ap.i1 * stride[k];
      wt[k][cnt[k]++] = ap.t;
    }
  }
  for (int l = 0; l < cnt[3]; ++l)
    for (int k = 0; k < cnt[2]; ++k)
      for (int j = 0; j < cnt[1]; ++j)
        for (int i = 0; i < cnt[0]; ++i) {
          const double w = 1 * wt[0][i] * wt[1][j] * wt[2][k] * wt[3][l];
          if (w == 0) continue;
          const double* v = values_.data() + off[0][i] + off[1][j] + off[2][k] + off[3][l];
          for (std::size_t c = 0; c < n; ++c) out[c] += w * v[c];
        }
}

bool BsdfTable::covers(const std::array<double, 4>& p) const noexcept {
  if (values_.empty()) return false;
  constexpr double kEps = 1e-9;
  const auto inside = [](const std::vector<double>& n, double x) {
    return n.size() < 2 || (x >= n.front() - kEps && x <= n.back() + kEps);
  };
  if (!inside(axes_.p0, p[0]) || !inside(axes_.p2, p[2])) return false;
  const double period = p3_period(param_, reduction_);
  const AxisPos pos[4] = {clamp_pos(axes_.p0, p[0]),
                          isotropic() ? AxisPos{} : azimuth_pos(axes_.p1, p[1], 360.0, false),
                          clamp_pos(axes_.p2, p[2]),
                          azimuth_pos(axes_.p3, p[3], period, reduction_.bilateral)};
  const std::size_t ch = channels();
  for (int corner = 0; corner < 16; ++corner) {
    std::size_t i[4];
    bool used = true;
    for (int k = 0; k < 4; ++k) {
      const bool hi = (corner >> k) & 1;
      const double w = hi ? pos[k].t : 1 - pos[k].t;
      used = used && w > kEps;  // a direction on a node, up to rounding, uses that node alone
      i[k] = hi ? pos[k].i1 : pos[k].i0;
    }
    if (!used) continue;
    const double* v = values_.data() + index(i[0], i[1], i[2], i[3]) * ch;
    if (std::all_of(v, v + ch, [](double x) { return x == 0; })) return false;
  }
  return true;
}

void BsdfTable::eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const noexcept {
  interpolate(coords(wi, wo), out);
}

// Both build the new table field by field: copying *this first would copy the values too.
BsdfTable BsdfTable::resampled(const std::vector<double>& nm) const {
  check_wavelengths(nm, "wavelengths");
  BsdfTable t;
  t.param_ = param_;
  t.axes_ = axes_;
  t.reduction_ = reduction_;
  t.values_ = nm == nm_ ? values_ : resample_channels(values_, nm_, nm);
  t.nm_ = nm;
  return t;
}

BsdfTable BsdfTable::weighted(std::span<const double> weights) const {
  BsdfTable t;
  t.param_ = param_;
  t.axes_ = axes_;
  t.reduction_ = reduction_;
  t.values_ = weigh_channels(values_, channels(), weights, "weights");
  check_values(t.values_, "table.values", kMaxF);
  return t;
}

// ---- SpecularTable -------------------------------------------------------------------------------

SpecularTable::SpecularTable(std::vector<double> theta_i, std::vector<double> phi_i,
                             std::vector<double> wavelengths_nm, std::vector<double> values)
    : theta_(std::move(theta_i)), phi_(std::move(phi_i)), nm_(std::move(wavelengths_nm)),
      values_(std::move(values)) {
  check_axis(theta_, "specular.p0", 0, 90, false);
  check_axis(phi_, "specular.p1", 0, 360, true);
  check_wavelengths(nm_, "specular.wavelengths");
  const std::size_t total =
      checked_size({theta_.size(), std::max<std::size_t>(1, phi_.size()), channels()}, "specular");
  if (values_.size() != total)
    throw Error::invalid("specular.values",
                         fmt::format("has {} entries, the axes need {}", values_.size(), total));
  check_values(values_, "specular.values", 1.0);
}

void SpecularTable::interpolate(double theta_deg, double phi_deg,
                                std::span<double> out) const noexcept {
  std::fill(out.begin(), out.end(), 0.0);
  if (values_.empty()) return;
  const AxisPos a0 = clamp_pos(theta_, theta_deg);
  const AxisPos a1 = phi_.empty() ? AxisPos{} : azimuth_pos(phi_, phi_deg, 360.0, false);
  const std::size_t ch = channels(), n0 = theta_.size();
  const std::size_t n = std::min(ch, out.size());
  for (int corner = 0; corner < 4; ++corner) {
    const bool h0 = corner & 1, h1 = (corner >> 1) & 1;
    const double w = (h0 ? a0.t : 1 - a0.t) * (h1 ? a1.t : 1 - a1.t);
    if (w == 0) continue;
    const double* v = values_.data() + ((h1 ? a1.i1 : a1.i0) * n0 + (h0 ? a0.i1 : a0.i0)) * ch;
    for (std::size_t c = 0; c < n; ++c) out[c] += w * v[c];
  }
}

SpecularTable SpecularTable::resampled(const std::vector<double>& nm) const {
  check_wavelengths(nm, "wavelengths");
  SpecularTable t = *this;
  if (nm != nm_) t.values_ = resample_channels(values_, nm_, nm);
  t.nm_ = nm;
  return t;
}

SpecularTable SpecularTable::weighted(std::span<const double> weights) const {
  SpecularTable t = *this;
  t.values_ = weigh_channels(values_, channels(), weights, "weights");
  t.nm_.clear();
  check_values(t.values_, "specular.values", 1.0);
  return t;
}

}  // namespace gonio::twin
