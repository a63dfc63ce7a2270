// TableSampler — importance sampling of a tabulated BSDF from the receiver side.
//
// Given wo, draw wi with a density close to f̄(wi, wo)·|cos θi| (f̄ the channel mean). For a
// set of receiver nodes (θ every 2°, and φ every 15° when the table is anisotropic) the
// sampler tabulates that product on cells of (r, a): r the angle from the mirror image s of
// the node direction, a the azimuth about s (MirrorFrame), one grid for reflection (wi on the
// receiver's side) and one for transmission (wi on the other side, described in its mirror
// image, so that the straight-through direction sits at r = 0 too). Each cell holds the
// largest value among its corners and centre, so a cell where f > 0 rarely gets zero mass.
// A query wo mixes the bracketing nodes with their interpolation weights times their
// integrals, applied in wo's own frame, so narrow lobes stay centred between nodes.
// A small defensive share (cosine-weighted over each hemisphere the table covers) keeps the
// density positive wherever f can be. pdf() evaluates the same mixture, so it matches the
// samples exactly.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "gonio/twin/bsdf.hpp"
#include "tabulated/common.hpp"

namespace gonio::twin::detail {

class TableSampler {
 public:
  using Density = std::function<double(const Vec3& wi, const Vec3& wo)>;

  static constexpr double kDefensive = 0.05;
  static constexpr double kThetaStepDeg = 2.0;
  static constexpr double kPhiStepDeg = 15.0;
  static constexpr int kAzimuthCells = 36;

  // `f` is f̄(wi, wo) >= 0; reflection / transmission say which hemispheres of wi (relative to
  // wo) the table covers; anisotropic adds receiver-azimuth nodes. A node's grids are built
  // on first use (thread-safe), so only the receiver directions actually queried cost time.
  TableSampler(Density f, bool reflection, bool transmission, bool anisotropic);

  std::optional<BsdfSample> sample(const Vec3& wo, double u_lobe, Vec2 u) const;
  double pdf(const Vec3& wo, const Vec3& wi) const;

  // Radial cell edges of every grid, degrees from the mirror direction.
  static const std::vector<double>& radial_edges_deg();

 private:
  // Piecewise-constant density over (r, a) cells, uniform in solid angle inside a cell.
  struct Grid {
    std::vector<double> value;    // per cell, rows = radial cells, kAzimuthCells columns
    std::vector<double> row_cdf;  // radial marginal, size rows + 1
    std::vector<double> col_cdf;  // per row, size rows·(kAzimuthCells + 1)
    double integral = 0;          // Σ value·Ω
  };
  struct Component {
    const Grid* grid;
    bool transmission;
    double weight;
  };

  // The mixture for one wo (components, their total, the mirror frame). Renderers ask for
  // many wi at the same wo in a row, so the last one is kept per thread (keyed by id_).
  struct Query {
    std::uint64_t owner = 0;
    Vec3 wo{};
    Component comps[8];
    std::size_t n = 0;
    double total = 0;
    tab::MirrorFrame frame;
  };
  const Query& query(const Vec3& wo) const;

  const Grid& grid(std::size_t theta_node, std::size_t phi_node, bool transmission) const;
  void build_node(std::size_t theta_node, std::size_t phi_node) const;
  std::size_t components(const Vec3& wo, Component out[8]) const;
  double grid_density(const Grid& g, double r_deg, double a_rad) const;
  double defensive_pdf(const Vec3& wi) const;

  Density f_;
  std::uint64_t id_;                      // unique per sampler, for the per-thread Query
  std::vector<std::uint8_t> radial_row_;  // radial row per quarter degree (edges are multiples)
  bool reflection_, transmission_, anisotropic_;
  std::size_t theta_nodes_, phi_nodes_;
  std::vector<double> cos_edges_;         // cos of radial edges (decreasing)
  std::vector<double> cell_solid_angle_;  // per radial row
  std::vector<double> centre_cos_;        // cos of the radial cell centres
  // Per node (phi·theta_nodes + theta): reflection and transmission grids, built once.
  mutable std::vector<std::array<Grid, 2>> grids_;
  std::unique_ptr<std::once_flag[]> built_;
};

}  // namespace gonio::twin::detail
