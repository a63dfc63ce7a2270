// TableSampler — importance sampling of tabulated BSDFs (see sampling.hpp for the scheme).
//
// Why cells about the mirror direction rather than the table's own (θ, φ) nodes: a table
// may be spherical, specular or half-difference, and measured tables need not be reciprocal;
// tabulating f̄·cos itself for the receiver direction in a frame that follows the specular
// peak gives one sampler for all of them, exact in its pdf and good for narrow lobes.
#include "tabulated/sampling.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>

#include "tabulated/common.hpp"

namespace gonio::twin::detail {
namespace {

constexpr double kCellAz = 2 * kPi / TableSampler::kAzimuthCells;

// Index i such that cdf[i] <= x < cdf[i + 1], skipping empty cells.
std::size_t find_interval(const double* cdf, std::size_t n, double x) noexcept {
  const auto it = std::upper_bound(cdf, cdf + n + 1, x);
  std::size_t i = static_cast<std::size_t>(it - cdf);
  i = i == 0 ? 0 : i - 1;
  i = std::min(i, n - 1);
  while (i > 0 && cdf[i + 1] <= cdf[i]) --i;      // x at the top: last non-empty cell
  while (i + 1 < n && cdf[i + 1] <= cdf[i]) ++i;  // empty cell at the bottom
  return i;
}

Vec3 cosine_hemisphere(Vec2 u) noexcept {
  const double r = std::sqrt(u.x), phi = 2 * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0, 1 - u.x))};
}

}  // namespace

const std::vector<double>& TableSampler::radial_edges_deg() {
  static const std::vector<double> edges{0,  0.25, 0.5, 0.75, 1,  1.5, 2,  2.5, 3,   4,   5,
                                         6,  8,    10,  12.5, 15, 20,  25, 30,  35,  40,  50,
                                         60, 70,   80,  90,   105, 120, 135, 150, 165, 180};
  return edges;
}

TableSampler::TableSampler(Density f, bool reflection, bool transmission, bool anisotropic)
    : f_(std::move(f)), reflection_(reflection), transmission_(transmission),
      anisotropic_(anisotropic) {
  static std::atomic<std::uint64_t> next_id{1};
  id_ = next_id++;
  const auto& edges = radial_edges_deg();
  const std::size_t rows = edges.size() - 1;
  // Every edge is a multiple of 0.25°, so the row of r is that of floor(4r) / 4.
  for (std::size_t q = 0, j = 0; q <= 4 * 180; ++q) {
    while (j + 1 < rows && edges[j + 1] <= 0.25 * static_cast<double>(q)) ++j;
    radial_row_.push_back(static_cast<std::uint8_t>(j));
  }
  theta_nodes_ = static_cast<std::size_t>(std::lround(90.0 / kThetaStepDeg)) + 1;
  phi_nodes_ = anisotropic_ ? static_cast<std::size_t>(std::lround(360.0 / kPhiStepDeg)) : 1;
  for (const double e : edges) cos_edges_.push_back(std::cos(e * kDegToRad));
  cos_edges_.front() = 1;
  cos_edges_.back() = -1;
  for (std::size_t j = 0; j < rows; ++j) {
    cell_solid_angle_.push_back((cos_edges_[j] - cos_edges_[j + 1]) * kCellAz);
    centre_cos_.push_back(std::cos(0.5 * (edges[j] + edges[j + 1]) * kDegToRad));
  }
  grids_.resize(theta_nodes_ * phi_nodes_);
  built_ = std::make_unique<std::once_flag[]>(theta_nodes_ * phi_nodes_);
}

void TableSampler::build_node(std::size_t k, std::size_t l) const {
  const std::size_t rows = cos_edges_.size() - 1;
  constexpr std::size_t cols = kAzimuthCells;
  // f̄·cos at a frame direction d (d.z > 0): wi = d for reflection, its mirror image for
  // transmission; both share the cosine d.z.
  const double theta = std::min(static_cast<double>(k) * kThetaStepDeg, 89.5) * kDegToRad;
  const double phi = static_cast<double>(l) * kPhiStepDeg * kDegToRad;
  const Vec3 wo = spherical(theta, phi);
  const auto frame = tab::MirrorFrame::of(wo);
  const auto point = [&](const Vec3& d, double& refl, double& trans) {
    refl = trans = 0;
    if (!(d.z > 0)) return;
    if (reflection_) refl = std::max(0.0, f_(d, wo)) * d.z;
    if (transmission_) trans = std::max(0.0, f_(tab::flip_z(d), wo)) * d.z;
  };
  // Evaluation points: corners (rows + 1) × cols (periodic in a) and cell centres.
  std::vector<double> corner[2], centre[2];
  for (int s = 0; s < 2; ++s) {
    corner[s].assign((rows + 1) * cols, 0.0);
    centre[s].assign(rows * cols, 0.0);
  }
  for (std::size_t j = 0; j <= rows; ++j)
    for (std::size_t m = 0; m < cols; ++m)
      point(frame.direction(cos_edges_[j], static_cast<double>(m) * kCellAz),
            corner[0][j * cols + m], corner[1][j * cols + m]);
  for (std::size_t j = 0; j < rows; ++j)
    for (std::size_t m = 0; m < cols; ++m)
      point(frame.direction(centre_cos_[j], (static_cast<double>(m) + 0.5) * kCellAz),
            centre[0][j * cols + m], centre[1][j * cols + m]);

  for (int s = 0; s < 2; ++s) {
    Grid& g = grids_[l * theta_nodes_ + k][static_cast<std::size_t>(s)];
    g.value.assign(rows * cols, 0.0);
    g.row_cdf.assign(rows + 1, 0.0);
    g.col_cdf.assign(rows * (cols + 1), 0.0);
    const auto& cv = corner[s];
    for (std::size_t j = 0; j < rows; ++j) {
      double row = 0;
      for (std::size_t m = 0; m < cols; ++m) {
        const std::size_t m1 = (m + 1) % cols;
        const double v = std::max({cv[j * cols + m], cv[j * cols + m1], cv[(j + 1) * cols + m],
                                   cv[(j + 1) * cols + m1], centre[s][j * cols + m]});
        g.value[j * cols + m] = v;
        row += v;
        g.col_cdf[j * (cols + 1) + m + 1] = row;
      }
      double* cc = &g.col_cdf[j * (cols + 1)];
      for (std::size_t m = 1; m <= cols; ++m)
        cc[m] = row > 0 ? cc[m] / row : static_cast<double>(m) / static_cast<double>(cols);
      cc[cols] = 1;
      g.row_cdf[j + 1] = g.row_cdf[j] + row * cell_solid_angle_[j];
    }
    g.integral = g.row_cdf[rows];
    for (auto& c : g.row_cdf) c = g.integral > 0 ? c / g.integral : 0;
    if (g.integral > 0) g.row_cdf[rows] = 1;
  }
}

const TableSampler::Grid& TableSampler::grid(std::size_t theta_node, std::size_t phi_node,
                                             bool transmission) const {
  const std::size_t node = phi_node * theta_nodes_ + theta_node;
  std::call_once(built_[node], [&] { build_node(theta_node, phi_node); });
  return grids_[node][transmission ? 1 : 0];
}

std::size_t TableSampler::components(const Vec3& wo, Component out[8]) const {
  const double theta = tab::polar_deg(wo) / kThetaStepDeg;
  const std::size_t k = std::min(static_cast<std::size_t>(std::max(0.0, std::floor(theta))),
                                 theta_nodes_ - 2);
  const double t = std::clamp(theta - static_cast<double>(k), 0.0, 1.0);
  std::array<std::pair<std::size_t, double>, 2> th{{{k, 1 - t}, {k + 1, t}}};
  std::array<std::pair<std::size_t, double>, 2> ph{{{0, 1.0}, {0, 0.0}}};
  if (anisotropic_) {
    const double phi = tab::azimuth_deg(wo) / kPhiStepDeg;
    const std::size_t l = static_cast<std::size_t>(std::floor(phi)) % phi_nodes_;
    const double s = std::clamp(phi - std::floor(phi), 0.0, 1.0);
    ph = {{{l, 1 - s}, {(l + 1) % phi_nodes_, s}}};
  }
  std::size_t n = 0;
  for (const auto& [pk, pw] : ph)
    for (const auto& [tk, tw] : th) {
      const double w = pw * tw;
      if (w <= 0) continue;
      for (int side = 0; side < 2; ++side) {
        if ((side == 0 && !reflection_) || (side == 1 && !transmission_)) continue;
        const Grid& g = grid(tk, pk, side == 1);
        if (g.integral > 0) out[n++] = {&g, side == 1, w * g.integral};
      }
    }
  return n;
}

const TableSampler::Query& TableSampler::query(const Vec3& wo) const {
  thread_local Query q;
  if (q.owner != id_ || q.wo.x != wo.x || q.wo.y != wo.y || q.wo.z != wo.z) {
    q.owner = id_;
    q.wo = wo;
    q.n = components(wo, q.comps);
    q.total = 0;
    for (std::size_t c = 0; c < q.n; ++c) q.total += q.comps[c].weight;
    q.frame = tab::MirrorFrame::of(wo);
  }
  return q;
}

double TableSampler::grid_density(const Grid& g, double r_deg, double a_rad) const {
  const double quarter = std::clamp(std::floor(4 * r_deg), 0.0, 4 * 180.0);
  const std::size_t j = radial_row_[static_cast<std::size_t>(quarter)];
  const auto m = std::min(static_cast<std::size_t>(std::max(0.0, a_rad / kCellAz)),
                          static_cast<std::size_t>(kAzimuthCells) - 1);
  return g.value[j * kAzimuthCells + m] / g.integral;
}

double TableSampler::defensive_pdf(const Vec3& wi) const {
  const double hemispheres = (reflection_ ? 1.0 : 0.0) + (transmission_ ? 1.0 : 0.0);
  if (hemispheres == 0) return 0;
  if ((wi.z > 0 && reflection_) || (wi.z < 0 && transmission_))
    return std::abs(wi.z) * kInvPi / hemispheres;
  return 0;
}

double TableSampler::pdf(const Vec3& wo_in, const Vec3& wi_in) const {
  Vec3 wo = wo_in, wi = wi_in;
  if (wo.z < 0) {
    wo = tab::flip_z(wo);
    wi = tab::flip_z(wi);
  }
  const Query& q = query(wo);
  const Component* comps = q.comps;
  const std::size_t n = q.n;
  const double total = q.total;
  const double def = defensive_pdf(wi);
  if (!(total > 0)) return def;
  const auto& frame = q.frame;
  double r[2] = {0, 0}, a[2] = {0, 0};
  bool have[2] = {false, false};
  double mix = 0;
  for (std::size_t c = 0; c < n; ++c) {
    const int side = comps[c].transmission ? 1 : 0;
    if (!have[side]) {
      frame.angles(side ? tab::flip_z(wi) : wi, r[side], a[side]);
      have[side] = true;
    }
    mix += comps[c].weight * grid_density(*comps[c].grid, r[side], a[side]);
  }
  return kDefensive * def + (1 - kDefensive) * mix / total;
}

std::optional<BsdfSample> TableSampler::sample(const Vec3& wo_in, double u_lobe, Vec2 u) const {
  Vec3 wo = wo_in;
  const bool flip = wo.z < 0;
  if (flip) wo = tab::flip_z(wo);
  // A copy: pdf() below may replace this thread's Query.
  const Query q = query(wo);
  const Component* comps = q.comps;
  const std::size_t n = q.n;
  const double total = q.total;

  Vec3 wi;
  if (total > 0 && u_lobe >= kDefensive) {
    double x = (u_lobe - kDefensive) / (1 - kDefensive) * total;
    std::size_t c = 0;
    while (c + 1 < n && x >= comps[c].weight) x -= comps[c++].weight;
    const Grid& g = *comps[c].grid;
    const std::size_t rows = cos_edges_.size() - 1;
    const std::size_t j = find_interval(g.row_cdf.data(), rows, u.x);
    const double pr = g.row_cdf[j + 1] - g.row_cdf[j];
    const double ur = pr > 0 ? std::clamp((u.x - g.row_cdf[j]) / pr, 0.0, 1.0) : 0.5;
    const double cos_r = cos_edges_[j] - ur * (cos_edges_[j] - cos_edges_[j + 1]);
    const double* cc = &g.col_cdf[j * (kAzimuthCells + 1)];
    const std::size_t m = find_interval(cc, kAzimuthCells, u.y);
    const double pa = cc[m + 1] - cc[m];
    const double ua = pa > 0 ? std::clamp((u.y - cc[m]) / pa, 0.0, 1.0) : 0.5;
    const double a = (static_cast<double>(m) + ua) * kCellAz;
    const Vec3 d = q.frame.direction(cos_r, a);
    wi = comps[c].transmission ? tab::flip_z(d) : d;
  } else {
    const double v = total > 0 ? u_lobe / kDefensive : u_lobe;
    bool below = transmission_;
    if (reflection_ && transmission_) below = v >= 0.5;
    const Vec3 d = cosine_hemisphere(u);
    wi = below ? tab::flip_z(d) : d;
  }
  wi = normalize(wi);
  if (flip) wi = tab::flip_z(wi);
  const double p = pdf(wo_in, wi);
  if (!(p > 0) || !std::isfinite(p)) return std::nullopt;
  return BsdfSample{wi, p};
}

}  // namespace gonio::twin::detail
