// TabulatedBsdf — a Bsdf served from tables (BRDF, BTDF, ideal specular parts), and
// tabulate(), which turns any Bsdf into such tables on a spherical grid.
//
// The tables are resampled once onto the model's wavelength grid so that eval() is one
// multilinear interpolation carrying every channel; a grey channel-mean copy feeds the
// sampler, which is built on first use (most callers only evaluate).
#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/tabulated.hpp"
#include "tabulated/common.hpp"
#include "tabulated/sampling.hpp"

namespace gonio::twin {
namespace {

BsdfTable grey(const BsdfTable& t) {
  const std::vector<double> w(t.channels(), 1.0 / static_cast<double>(t.channels()));
  return t.weighted(w);
}

}  // namespace

TabulatedBsdf::TabulatedBsdf(const WavelengthGrid& grid, TabulatedParts parts, std::string spec)
    : Bsdf(grid), parts_(std::move(parts)), spec_(std::move(spec)) {
  if (grid.empty()) throw Error::invalid("wavelengths", "needs at least one wavelength");
  if (parts_.empty()) throw Error::invalid("tabulated", "holds no table");
  if (parts_.btdf && parts_.btdf->param() == TableParam::half_difference)
    throw Error(Errc::unsupported, "a BTDF in half-difference angles is not supported", "btdf");
  const auto& nm = grid.values();
  on_grid_.name = parts_.name;
  if (parts_.brdf) {
    on_grid_.brdf = parts_.brdf->resampled(nm);
    brdf_mean_ = grey(*on_grid_.brdf);
  }
  if (parts_.btdf) {
    on_grid_.btdf = parts_.btdf->resampled(nm);
    btdf_mean_ = grey(*on_grid_.btdf);
  }
  if (parts_.specular_reflectance)
    on_grid_.specular_reflectance = parts_.specular_reflectance->resampled(nm);
  if (parts_.specular_transmittance)
    on_grid_.specular_transmittance = parts_.specular_transmittance->resampled(nm);
}

TabulatedBsdf::TabulatedBsdf(const WavelengthGrid& grid, const AngularGrid& angles,
                             std::vector<double> table_nm, std::vector<double> brdf,
                             std::vector<double> btdf, std::string spec)
    : TabulatedBsdf(
          grid,
          [&] {
            if (brdf.empty() && btdf.empty())
              throw Error::invalid("tabulated", "needs BRDF or BTDF values");
            TabulatedParts p;
            const BsdfTable::Axes axes{angles.theta_i, angles.phi_i, angles.theta_o, angles.phi_o};
            const TableReduction red{angles.bilateral, false};
            if (!brdf.empty())
              p.brdf = BsdfTable(TableParam::spherical, axes, table_nm, std::move(brdf), red);
            if (!btdf.empty())
              p.btdf = BsdfTable(TableParam::spherical, axes, table_nm, std::move(btdf), red);
            return p;
          }(),
          std::move(spec)) {}

TabulatedBsdf::~TabulatedBsdf() = default;

void TabulatedBsdf::eval(const Vec3& wi_in, const Vec3& wo_in, std::span<double> out) const {
  std::fill(out.begin(), out.end(), 0.0);
  Vec3 wi = wi_in, wo = wo_in;
  if (wi.z < 0) {  // light from below: the mirror image (two-sided sample)
    wi = tab::flip_z(wi);
    wo = tab::flip_z(wo);
  }
  if (wo.z >= 0) {
    if (on_grid_.brdf) on_grid_.brdf->eval(wi, wo, out);
  } else if (on_grid_.btdf) {
    on_grid_.btdf->eval(wi, tab::flip_z(wo), out);
  }
}

double TabulatedBsdf::eval_mean(const Vec3& wi_in, const Vec3& wo_in) const noexcept {
  Vec3 wi = wi_in, wo = wo_in;
  if (wi.z < 0) {
    wi = tab::flip_z(wi);
    wo = tab::flip_z(wo);
  }
  double v = 0;
  if (wo.z >= 0) {
    if (brdf_mean_) brdf_mean_->eval(wi, wo, {&v, 1});
  } else if (btdf_mean_) {
    btdf_mean_->eval(wi, tab::flip_z(wo), {&v, 1});
  }
  return v;
}

const detail::TableSampler& TabulatedBsdf::sampler() const {
  std::call_once(sampler_once_, [this] {
    const bool aniso = (brdf_mean_ && !brdf_mean_->isotropic()) ||
                       (btdf_mean_ && !btdf_mean_->isotropic());
    sampler_ = std::make_unique<detail::TableSampler>(
        [this](const Vec3& wi, const Vec3& wo) { return eval_mean(wi, wo); },
        brdf_mean_.has_value(), btdf_mean_.has_value(), aniso);
  });
  return *sampler_;
}

std::optional<BsdfSample> TabulatedBsdf::sample_wi(const Vec3& wo, double u_lobe, Vec2 u) const {
  if (!brdf_mean_ && !btdf_mean_) return std::nullopt;
  return sampler().sample(wo, u_lobe, u);
}

double TabulatedBsdf::pdf(const Vec3& wo, const Vec3& wi) const {
  if (!brdf_mean_ && !btdf_mean_) return 0;
  return sampler().pdf(wo, wi);
}

bool TabulatedBsdf::has_delta() const noexcept {
  return on_grid_.specular_reflectance.has_value() || on_grid_.specular_transmittance.has_value();
}

void TabulatedBsdf::delta_lobes(const Vec3& wo_in, std::vector<DeltaLobe>& out) const {
  out.clear();
  if (!has_delta()) return;
  const bool below = wo_in.z < 0;
  const Vec3 wo = below ? tab::flip_z(wo_in) : wo_in;
  // Incidence of the lobe seen from its source side: the mirror and the straight-through
  // direction both make the angle θ(wo) with the normal, at the azimuth opposite to wo.
  const double theta = tab::polar_deg(wo);
  const double phi = std::fmod(tab::azimuth_deg(wo) + 180.0, 360.0);
  const auto push = [&](const SpecularTable& t, Vec3 wi) {
    DeltaLobe lobe{below ? tab::flip_z(wi) : wi, std::vector<double>(channels(), 0.0)};
    t.interpolate(theta, phi, lobe.weight);
    out.push_back(std::move(lobe));
  };
  if (on_grid_.specular_reflectance) push(*on_grid_.specular_reflectance, {-wo.x, -wo.y, wo.z});
  if (on_grid_.specular_transmittance) push(*on_grid_.specular_transmittance, -wo);
}

// ---- tabulate ------------------------------------------------------------------------------------

BsdfTable tabulate(const Bsdf& bsdf, const AngularGrid& g, bool transmission) {
  const BsdfTable::Axes axes{g.theta_i, g.phi_i, g.theta_o, g.phi_o};
  // Validate the grid (and the size) before evaluating anything, naming the grid's fields.
  const std::size_t ch = bsdf.channels();
  try {
    BsdfTable::check_axes(TableParam::spherical, axes, {g.bilateral, false}, ch);
  } catch (const Error& e) {
    static constexpr std::pair<std::string_view, std::string_view> kNames[] = {
        {"table.p0", "grid.theta_i"}, {"table.p1", "grid.phi_i"},
        {"table.p2", "grid.theta_o"}, {"table.p3", "grid.phi_o"}, {"table", "grid"}};
    std::string field = e.field(), msg = e.what();
    for (const auto& [from, to] : kNames)
      if (field.rfind(from, 0) == 0) {
        field = std::string(to) + field.substr(from.size());
        if (const auto pos = msg.find(from); pos != std::string::npos)
          msg.replace(pos, from.size(), to);
        break;
      }
    throw Error(e.code(), msg, field);
  }
  const bool iso = g.phi_i.empty();
  const std::size_t n1 = iso ? 1 : g.phi_i.size();
  std::vector<double> values;
  values.reserve(g.theta_i.size() * n1 * g.theta_o.size() * g.phi_o.size() * ch);
  std::vector<double> f(ch);
  for (std::size_t i3 = 0; i3 < g.phi_o.size(); ++i3)
    for (std::size_t i2 = 0; i2 < g.theta_o.size(); ++i2)
      for (std::size_t i1 = 0; i1 < n1; ++i1)
        for (std::size_t i0 = 0; i0 < g.theta_i.size(); ++i0) {
          // Isotropic: wi in the plane of measurement (azimuth 180°, the convention at
          // normal incidence too) and φo relative to it; anisotropic: absolute azimuths.
          const double phi_i = iso ? 180.0 : g.phi_i[i1];
          const Vec3 wi = spherical(g.theta_i[i0] * kDegToRad, phi_i * kDegToRad);
          const double phi_o = iso ? phi_i + g.phi_o[i3] : g.phi_o[i3];
          Vec3 wo = spherical(g.theta_o[i2] * kDegToRad, phi_o * kDegToRad);
          if (transmission) wo = tab::flip_z(wo);
          bsdf.eval(wi, wo, f);
          for (std::size_t c = 0; c < ch; ++c) {
            if (!std::isfinite(f[c]) || f[c] < 0)
              throw Error(Errc::internal,
                          fmt::format("model '{}' gives f = {} at θi={:g}, φi={:g}, θo={:g}, "
                                      "φo={:g}, channel {}",
                                      bsdf.spec(), f[c], g.theta_i[i0], phi_i, g.theta_o[i2],
                                      g.phi_o[i3], c),
                          "tabulate");
            values.push_back(f[c]);
          }
        }
  return BsdfTable(TableParam::spherical, axes, bsdf.wavelengths().values(), std::move(values),
                   {g.bilateral, false});
}

TabulatedParts tabulate_parts(const Bsdf& bsdf, const AngularGrid& g, bool reflection,
                              bool transmission) {
  TabulatedParts p;
  if (reflection) p.brdf = tabulate(bsdf, g, false);
  if (transmission) p.btdf = tabulate(bsdf, g, true);
  if (bsdf.has_delta()) {
    const bool iso = g.phi_i.empty();
    const std::size_t n1 = iso ? 1 : g.phi_i.size(), ch = bsdf.channels();
    std::vector<double> refl(g.theta_i.size() * n1 * ch, 0.0), trans(refl.size(), 0.0);
    bool any_r = false, any_t = false;
    std::vector<DeltaLobe> lobes;
    for (std::size_t i1 = 0; i1 < n1; ++i1)
      for (std::size_t i0 = 0; i0 < g.theta_i.size(); ++i0) {
        // The receiver at the mirror (and straight-through) position of an incidence
        // θi, φi: wo at θi, azimuth φi + 180°.
        const double phi_i = iso ? 180.0 : g.phi_i[i1];
        const Vec3 wo = spherical(g.theta_i[i0] * kDegToRad, (phi_i + 180.0) * kDegToRad);
        bsdf.delta_lobes(wo, lobes);
        for (const auto& lobe : lobes) {
          const bool r = lobe.wi.z > 0;
          auto& dst = r ? refl : trans;
          (r ? any_r : any_t) = true;
          for (std::size_t c = 0; c < ch && c < lobe.weight.size(); ++c)
            dst[(i1 * g.theta_i.size() + i0) * ch + c] += lobe.weight[c];
        }
      }
    const auto& nm = bsdf.wavelengths().values();
    if (any_r) p.specular_reflectance = SpecularTable(g.theta_i, g.phi_i, nm, std::move(refl));
    if (any_t) p.specular_transmittance = SpecularTable(g.theta_i, g.phi_i, nm, std::move(trans));
  }
  return p;
}

}  // namespace gonio::twin
