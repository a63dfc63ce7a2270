// in_plane_table (in_plane.hpp): cells keyed (θi, |θr|, φo), then laid out in table order.
#include "gonio/twin/in_plane.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>
#include <set>
#include <utility>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio::twin {
namespace {

struct Cell {
  std::vector<double> sum;  // f per channel
  int count = 0;
};
using CellKey = std::array<double, 3>;  // θi, |θr|, φo

// φo of a reading: the receiver's side of the normal.
std::vector<double> sides_of(const Geometry& g) {
  if (g.theta_r > 0) return {180.0};
  if (g.theta_r < 0) return {0.0};
  return {0.0, 180.0};
}

std::string name_of(const InPlaneReading& r) {
  return r.index >= 0 ? fmt::format("point {} ({})", r.index, r.geometry.to_string())
                      : r.geometry.to_string();
}

// The table, with or without unmeasured nodes (`gaps`: null refuses them).
BsdfTable build(std::span<const InPlaneReading> readings, std::vector<double> wavelengths_nm,
                const InPlaneErrorText& text, std::vector<Geometry>* gaps) {
  const std::size_t channels = wavelengths_nm.size();
  std::set<double> ti, to, sides;
  std::map<CellKey, Cell> cells;
  for (const auto& r : readings) {
    const auto& g = r.geometry;
    if (!g.in_measurement_plane() || g.is_transmission())
      throw Error(Errc::unsupported,
                  fmt::format("{} is not an in-plane reflection geometry; {}", name_of(r),
                              text.remedy),
                  text.field);
    if (r.beta.size() != channels)
      throw Error(Errc::invalid_argument,
                  fmt::format("{} has {} values for {} wavelengths", name_of(r), r.beta.size(),
                              channels),
                  text.field);
    const double theta_o = std::abs(g.theta_r);
    ti.insert(g.theta_i);
    to.insert(theta_o);
    for (const double side : sides_of(g)) {
      sides.insert(side);
      auto& cell = cells[{g.theta_i, theta_o, side}];
      if (cell.sum.empty()) cell.sum.assign(channels, 0.0);
      for (std::size_t c = 0; c < channels; ++c) cell.sum[c] += std::max(0.0, r.beta[c]) / std::numbers::pi;
      ++cell.count;
    }
  }
  BsdfTable::Axes axes;
  axes.p0.assign(ti.begin(), ti.end());
  axes.p2.assign(to.begin(), to.end());
  axes.p3.assign(sides.begin(), sides.end());
  const auto &p0 = axes.p0, &p2 = axes.p2, &p3 = axes.p3;
  const auto signed_theta_r = [](double theta_o, double side) { return side > 90 ? theta_o : -theta_o; };
  std::vector<double> values(p0.size() * p2.size() * p3.size() * channels);
  for (std::size_t i3 = 0; i3 < p3.size(); ++i3)
    for (std::size_t i2 = 0; i2 < p2.size(); ++i2)
      for (std::size_t i0 = 0; i0 < p0.size(); ++i0) {
        const auto it = cells.find({p0[i0], p2[i2], p3[i3]});
        if (it == cells.end()) {
          if (!gaps)
            throw Error(Errc::unsupported,
                        fmt::format("{} are not a full grid: no point at θi = {:g}°, θr = {:g}°; {}",
                                    text.what, p0[i0], signed_theta_r(p2[i2], p3[i3]), text.remedy),
                        text.field);
          gaps->push_back(Geometry::in_plane(p0[i0], signed_theta_r(p2[i2], p3[i3])));
          continue;  // zeros: not measured
        }
        const std::size_t base = ((i3 * p2.size() + i2) * p0.size() + i0) * channels;
        for (std::size_t c = 0; c < channels; ++c)
          values[base + c] = it->second.sum[c] / it->second.count;
      }
  if (gaps) {
    // By θi then θr; θr = 0 lies on both sides and is one gap.
    const auto key = [](const Geometry& g) { return std::pair(g.theta_i, g.theta_r); };
    std::sort(gaps->begin(), gaps->end(), [&](const Geometry& a, const Geometry& b) { return key(a) < key(b); });
    gaps->erase(std::unique(gaps->begin(), gaps->end(),
                            [&](const Geometry& a, const Geometry& b) { return key(a) == key(b); }),
                gaps->end());
  }
  return BsdfTable(TableParam::spherical, std::move(axes), std::move(wavelengths_nm),
                   std::move(values), TableReduction{true, false});
}

}  // namespace

BsdfTable in_plane_table(std::span<const InPlaneReading> readings,
                         std::vector<double> wavelengths_nm, const InPlaneErrorText& text) {
  return build(readings, std::move(wavelengths_nm), text, nullptr);
}

InPlaneTable in_plane_table_with_gaps(std::span<const InPlaneReading> readings,
                                      std::vector<double> wavelengths_nm,
                                      const InPlaneErrorText& text) {
  InPlaneTable t;
  t.table = build(readings, std::move(wavelengths_nm), text, &t.gaps);
  return t;
}

std::vector<std::string> InPlaneTable::gap_ranges() const {
  // Runs of unmeasured nodes (ASCII: file headers are read by tools that expect it) along each incidence angle's row of signed θr nodes.
  std::vector<std::string> out;
  const auto& ax = table.axes();
  const bool back = std::ranges::find(ax.p3, 0.0) != ax.p3.end();
  const bool front = std::ranges::find(ax.p3, 180.0) != ax.p3.end();
  std::set<double> row;
  for (const double t : ax.p2) {
    if (back) row.insert(-t);
    if (front) row.insert(t);
  }
  for (const double ti : ax.p0) {
    std::string ranges;
    std::optional<double> first, last;
    const auto close = [&] {
      if (!first) return;
      ranges += (ranges.empty() ? "" : ", ") +
                (*first == *last ? fmt::format("{:g}", *first)
                                 : fmt::format("{:g} to {:g}", *first, *last));
      first.reset();
    };
    for (const double tr : row) {
      const bool gap = std::binary_search(gaps.begin(), gaps.end(), Geometry::in_plane(ti, tr),
                                          [](const Geometry& a, const Geometry& b) {
                                            return std::pair(a.theta_i, a.theta_r) < std::pair(b.theta_i, b.theta_r);
                                          });
      if (!gap) {
        close();
        continue;
      }
      if (!first) first = tr;
      last = tr;
    }
    close();
    if (!ranges.empty()) out.push_back(fmt::format("theta_i = {:g} deg: theta_r = {} deg", ti, ranges));
  }
  return out;
}

}  // namespace gonio::twin
