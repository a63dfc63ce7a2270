// Tabulated BSDFs: measured (or virtually measured) scattering functions kept as tables.
//
// A BsdfTable is one scattering function — a BRDF or a BTDF — sampled on a 4-D angular grid,
// per wavelength of the table, in one of the three parametrizations of the SSDD format
// (libbsdf doc/SsddFileFormatSpecification.md, "Parameterization types"). Angles in degrees:
//
//   spherical        p0 θi  p1 φi  p2 θo                                    p3 φo
//   specular         p0 θi  p1 φi  p2 angle between wo and the specular     p3 azimuth of wo
//                                     direction of wi ("radial")                about it
//   half_difference  p0 θh  p1 φh  p2 θd                                    p3 φd
//                    (Rusinkiewicz 1998, "A New Change of Variables for Efficient BRDF
//                    Representation")
//
// Frame (docs/architecture.md §2): normal +z, wi toward the source, wo toward the receiver, both pointing
// away from the surface. An empty p1 makes the table isotropic and p3 the azimuth of wo
// relative to that of wi (φo − φi), so p3 = 180° is the forward (specular) side of the plane
// of incidence and p3 = 0° the backward side. For the instrument's in-plane geometry
// (wi = (−sin θi, 0, cos θi), wr = (sin θr, 0, cos θr)) that is φo = 180° for θr > 0 and
// φo = 0° for θr < 0. At normal incidence the azimuth of wi is taken as 180°, the limit along
// that plane.
// In the specular parametrization azimuth 0 points from the specular direction toward the
// normal and grows counter-clockwise seen from above (+z), as in the Zemax/Radiant IS-SA
// format. A BTDF describes wo in its mirror image through the sample plane (θo measured from
// −z); the straight-through direction −wi then plays the role of the specular direction.
//
// Values are f in sr⁻¹ (no cosine factor), finite and >= 0, stored with the channel fastest
// and p0 next, as in SSDD: values[((((i3·n2 + i2)·n1 + i1)·n0 + i0)·channels + c].
// Reductions: `bilateral` — p3 covers one side of the plane of incidence ([0, 180], or
// [0, 90] for a reciprocal half-difference table) and is mirrored; `reciprocal` — only for
// half_difference: φd and φd + 180° are the same sample (MERL's layout).
//
// Interpolation is multilinear in (p0, p1, p2, p3): polar axes clamp beyond their first and
// last node, azimuth axes wrap around (or mirror, with `bilateral`).
//
// TabulatedBsdf (below) is the Bsdf built from a BRDF and/or BTDF table plus optional
// specular reflectance / transmittance tables (ideal specular parts, served as delta lobes).
// Data are resampled onto the model's wavelength grid at construction (linear in λ,
// constant beyond the table's ends; a table without wavelengths is grey). The table
// describes the front side; light arriving from below (wi.z < 0) is evaluated in the mirror
// image through the sample plane (a two-sided sample).
#pragma once

#include <array>
#include <cstddef>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "gonio/proto/enum_text.hpp"
#include "gonio/twin/bsdf.hpp"

namespace gonio::twin {

enum class TableParam { spherical, specular, half_difference };

inline constexpr EnumNames<TableParam, 3> kTableParamNames{{
    {TableParam::spherical, "spherical"},
    {TableParam::specular, "specular"},
    {TableParam::half_difference, "half_difference"},
}};
constexpr const auto& enum_names(TableParam) { return kTableParamNames; }  // proto/enum_text.hpp

struct TableReduction {
  bool bilateral = false;
  bool reciprocal = false;
  friend bool operator==(const TableReduction&, const TableReduction&) = default;
};

class BsdfTable {
 public:
  // Upper bound on nodes × channels, so that no file can make us allocate without limit.
  static constexpr std::size_t kMaxValues = std::size_t{1} << 26;
  static constexpr std::size_t kMaxNodes = 100000;  // per axis
  static constexpr double kMaxF = 1e12;             // sr⁻¹, far above any real peak

  struct Axes {
    std::vector<double> p0, p1, p2, p3;  // degrees; p1 empty = isotropic
    friend bool operator==(const Axes&, const Axes&) = default;
  };

  BsdfTable() = default;
  // Validates everything (Error naming the offending field: "table.p2[3]", "table.values[17]").
  BsdfTable(TableParam param, Axes axes, std::vector<double> wavelengths_nm,
            std::vector<double> values, TableReduction reduction = {});
  // The axis and size checks of the constructor alone; returns the number of nodes.
  static std::size_t check_axes(TableParam param, const Axes& axes, TableReduction reduction,
                                std::size_t channels = 1);

  TableParam param() const noexcept { return param_; }
  const Axes& axes() const noexcept { return axes_; }
  const std::vector<double>& axis(int k) const;  // k = 0..3
  // Nodes along axis k as used by the interpolation (an isotropic table has one p1 node, 0).
  std::size_t nodes(int k) const noexcept;
  bool isotropic() const noexcept { return axes_.p1.empty(); }
  const TableReduction& reduction() const noexcept { return reduction_; }
  const std::vector<double>& wavelengths() const noexcept { return nm_; }
  std::size_t channels() const noexcept { return nm_.empty() ? 1 : nm_.size(); }
  const std::vector<double>& values() const noexcept { return values_; }
  std::size_t index(std::size_t i0, std::size_t i1, std::size_t i2, std::size_t i3) const noexcept;
  double at(std::size_t i0, std::size_t i1, std::size_t i2, std::size_t i3, std::size_t c) const {
    return values_[index(i0, i1, i2, i3) * channels() + c];
  }
  bool empty() const noexcept { return values_.empty(); }

  // Parameter coordinates (degrees) of a direction pair; wi and wo unit vectors with
  // wi.z >= 0 and wo.z >= 0 (a BTDF's wo already mirrored through the sample plane).
  std::array<double, 4> coords(const Vec3& wi, const Vec3& wo) const noexcept;
  // Multilinear interpolation at parameter coordinates, every channel (out.size() == channels()).
  void interpolate(const std::array<double, 4>& p, std::span<double> out) const noexcept;
  // f(wi, wo) for every channel: interpolate(coords(wi, wo)).
  void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const noexcept;
  // True when p lies inside the measured extent of the polar axes (p0, p2: no clamping to
  // the last node) and every node the interpolation at p uses holds a non-zero value in some
  // channel: a zero node is how tables from instruments mark a direction they did not
  // measure (IS-SA files write directions below the horizon as 0). What a fit may take as data.
  bool covers(const std::array<double, 4>& p) const noexcept;

  // The same table on other wavelengths (empty = grey: the channel mean).
  BsdfTable resampled(const std::vector<double>& nm) const;
  // Grey table holding a weighted sum of channels (weights.size() == channels()).
  BsdfTable weighted(std::span<const double> weights) const;

  friend bool operator==(const BsdfTable&, const BsdfTable&) = default;

 private:
  TableParam param_ = TableParam::spherical;
  Axes axes_;
  std::vector<double> nm_;
  std::vector<double> values_;
  TableReduction reduction_;
};

// Reflectance (or transmittance) of an ideal specular part per incidence direction:
// p0 θi, p1 φi (empty = isotropic), values[(i1·n0 + i0)·channels + c] in [0, 1].
class SpecularTable {
 public:
  SpecularTable() = default;
  SpecularTable(std::vector<double> theta_i, std::vector<double> phi_i,
                std::vector<double> wavelengths_nm, std::vector<double> values);

  const std::vector<double>& theta_i() const noexcept { return theta_; }
  const std::vector<double>& phi_i() const noexcept { return phi_; }
  const std::vector<double>& wavelengths() const noexcept { return nm_; }
  std::size_t channels() const noexcept { return nm_.empty() ? 1 : nm_.size(); }
  const std::vector<double>& values() const noexcept { return values_; }
  // Linear in θi (clamped), periodic in φi; degrees.
  void interpolate(double theta_deg, double phi_deg, std::span<double> out) const noexcept;
  SpecularTable resampled(const std::vector<double>& nm) const;
  SpecularTable weighted(std::span<const double> weights) const;

  friend bool operator==(const SpecularTable&, const SpecularTable&) = default;

 private:
  std::vector<double> theta_, phi_, nm_, values_;
};

// Everything a tabulated file can hold. At least one member is set.
struct TabulatedParts {
  std::optional<BsdfTable> brdf;
  std::optional<BsdfTable> btdf;
  std::optional<SpecularTable> specular_reflectance;
  std::optional<SpecularTable> specular_transmittance;
  std::string name;  // free text from the file, may be empty

  bool empty() const noexcept {
    return !brdf && !btdf && !specular_reflectance && !specular_transmittance;
  }
  friend bool operator==(const TabulatedParts&, const TabulatedParts&) = default;
};

// A spherical grid to tabulate on (degrees). With phi_i empty the table is isotropic and
// phi_o relative to the incidence azimuth (180 = forward); `bilateral` declares phi_o to
// cover one side of the plane of incidence only.
struct AngularGrid {
  std::vector<double> theta_i, phi_i, theta_o, phi_o;
  bool bilateral = false;
};

namespace detail {
class TableSampler;
}

class TabulatedBsdf final : public Bsdf {
 public:
  // Throws Error(invalid_argument) when `parts` is empty or a part breaks its constraints.
  TabulatedBsdf(const WavelengthGrid& grid, TabulatedParts parts, std::string spec = "tabulated");
  // From plain arrays: a spherical table on `angles` with values laid out as in BsdfTable
  // (channel fastest, then θi, φi, θo, φo); `table_nm` empty means grey. Either array may be
  // empty (no BRDF / no BTDF), not both.
  TabulatedBsdf(const WavelengthGrid& grid, const AngularGrid& angles,
                std::vector<double> table_nm, std::vector<double> brdf,
                std::vector<double> btdf = {}, std::string spec = "tabulated");
  ~TabulatedBsdf() override;

  // The tables as given, on their own wavelengths (for writers and analysis).
  const TabulatedParts& parts() const noexcept { return parts_; }

  void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const override;
  std::optional<BsdfSample> sample_wi(const Vec3& wo, double u_lobe, Vec2 u) const override;
  double pdf(const Vec3& wo, const Vec3& wi) const override;
  void delta_lobes(const Vec3& wo, std::vector<DeltaLobe>& out) const override;
  bool has_delta() const noexcept override;
  std::string spec() const override { return spec_; }

  // Channel-mean f, the density the sampler follows (exposed for tests and diagnostics).
  double eval_mean(const Vec3& wi, const Vec3& wo) const noexcept;

 private:
  const detail::TableSampler& sampler() const;

  TabulatedParts parts_;   // as given
  TabulatedParts on_grid_;  // resampled onto wavelengths()
  std::optional<BsdfTable> brdf_mean_, btdf_mean_;  // grey, for sampling
  std::string spec_;
  mutable std::once_flag sampler_once_;
  mutable std::unique_ptr<detail::TableSampler> sampler_;
};

// Tabulates `bsdf` on a spherical grid: its BRDF (wi and wo above the sample) or its BTDF
// (wo below), on the model's own wavelength grid. Non-finite or negative values from the
// model are reported as Error(internal) naming the node.
BsdfTable tabulate(const Bsdf& bsdf, const AngularGrid& grid, bool transmission = false);
// Both parts as requested, plus the model's delta lobes (as specular reflectance /
// transmittance tables over theta_i) when it has any.
TabulatedParts tabulate_parts(const Bsdf& bsdf, const AngularGrid& grid, bool reflection = true,
                              bool transmission = false);

// ---- energy ---------------------------------------------------------------------------------
// Directional-hemispherical reflectance ∫ f cos θo dωo of a table (its transmittance for a
// BTDF table), per channel, at incidence θi (degrees, in the plane of measurement): the
// integral of the table's own multilinear interpolant — what a reader that interpolates
// the file gets — by a product midpoint rule about the specular direction, on the table's
// nodes subdivided (specular tables) or on a list refined toward the specular direction.
std::vector<double> table_albedo(const BsdfTable& table, double theta_i_deg);
// The same integral of a model's eval (reflection, delta lobes excluded), per channel, on
// radial breakpoints (degrees from the specular direction, 0…180) and azimuthal ones
// (0…180, mirrored onto the whole circle), each subdivided to ≤ 0.5° / 1°.
std::vector<double> model_albedo(const Bsdf& model, double theta_i_deg,
                                 const std::vector<double>& radial_edges,
                                 const std::vector<double>& azimuth_edges);
// On a default list refined toward the specular direction (suits lobes down to α ≈ 0.02).
std::vector<double> model_albedo(const Bsdf& model, double theta_i_deg);
// One message per θi whose table reflectance exceeds 1 in some channel, naming the angle
// (and the wavelength). Writers put these in the file's comments and return them.
std::vector<std::string> energy_warnings(const BsdfTable& table, bool transmission,
                                         std::span<const double> theta_i);

// ---- lobe-following grids -------------------------------------------------------------------
// A specular-parametrization grid (degrees): θi, radial angle from the specular direction,
// azimuth about it 0…180 (bilateral: the model is taken as isotropic and symmetric about the
// plane of incidence).
struct SpecularGrid {
  std::vector<double> theta_i, radial, azimuth;
};

struct LobeGridOptions {
  std::vector<double> theta_i;     // empty: 0:5:85
  double tolerance = 0.02;         // largest relative interpolation error along each axis
  double floor = 0.01;             // of f·cos θo, relative to max(f·cos θo, floor × its peak)
  double energy_tolerance = 0.02;  // largest relative error of the table's reflectance
  double azimuth_step = 15;        // the coarsest azimuth step, where nothing asks for less
  double min_radial_step = 0.02, min_azimuth_step = 0.25, min_incidence_step = 0.5;
  std::size_t max_nodes = 400;     // per axis
};

// The grid's reflectance against the model's (channel mean) at every θi node.
struct LobeGridReport {
  std::vector<double> theta_i, table, model;
  double worst = 0;      // largest relative error, nodes and halfway between them
  double tolerance = 0;  // interpolation tolerance finally used
};

// Refines radial and azimuthal nodes until linear interpolation of the model's channel-mean
// f along each axis, weighted by cos θo, stays within `tolerance` × max(f·cos θo,
// floor × peak) at a quarter, half and three quarters of every interval, at every θi
// (intervals with an end below the sample plane excepted); then checks
// the table's reflectance against the model's at every θi node and halfway between them,
// and while it is off by more than `energy_tolerance` halves the tolerance and adds θi
// nodes where the halfway check fails (at most four times).
SpecularGrid lobe_grid(const Bsdf& model, const LobeGridOptions& options = {},
                       LobeGridReport* report = nullptr);
// The model's BRDF on the grid, every channel (or their mean with `grey`): a bilateral
// specular table. Nodes below the sample plane hold the value at the horizon along the same
// azimuth, which keeps interpolation near grazing angles unbiased.
BsdfTable tabulate_specular(const Bsdf& model, const SpecularGrid& grid, bool grey = false);
// (wi, wo) of every node in table order (θi fastest, then radial, then azimuth), wo pulled
// onto the horizon where the node lies below it: for filling the grid by other means
// (virtual measurement).
std::vector<std::pair<Vec3, Vec3>> specular_grid_directions(const SpecularGrid& grid);

}  // namespace gonio::twin
