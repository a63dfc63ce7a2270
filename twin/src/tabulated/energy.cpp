// Directional-hemispherical reflectance of tables and models, and the lobe-following
// specular grid that `gonio-twin convert` tabulates models on.
//
// Why a lobe-following grid: a glossy lobe a few degrees wide, sampled at its peak on a
// spherical grid of 5° in θ and 15° in φ, is spread by multilinear interpolation over a
// whole grid cell — the table then reflects several times more light than the model at
// grazing incidence (conductor α = 0.1: 3.6 instead of 0.84 at θi = 85°). In the specular
// parametrization (the native one of the IS-SA format, and one of the SSDD format's) the lobe
// sits at radial angle 0 for every θi, and interpolation between incidence angles blends
// lobes of similar shape instead of shifting them; the radial and azimuthal nodes are then
// refined until interpolation stays within a tolerance of the model everywhere.
#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/tabulated.hpp"
#include "tabulated/common.hpp"

namespace gonio::twin {
namespace {

Vec3 incidence(double theta_i_deg) {
  const double t = theta_i_deg * kDegToRad;
  return {-std::sin(t), 0, std::cos(t)};
}

// Sub-intervals of [edges[k], edges[k+1]]: at least `min_sub` each, none wider than `max_w`.
std::vector<double> subdivide(const std::vector<double>& edges, int min_sub, double max_w) {
  std::vector<double> out{edges.front()};
  for (std::size_t k = 0; k + 1 < edges.size(); ++k) {
    const double w = edges[k + 1] - edges[k];
    if (!(w > 0)) continue;
    const int n = std::max(min_sub, static_cast<int>(std::ceil(w / max_w)));
    for (int s = 1; s <= n; ++s) out.push_back(edges[k] + w * s / n);
  }
  return out;
}

// ∫ g(wo) cos θo dω over the upper hemisphere, in the mirror frame of wi: radial angle r
// about the specular direction, azimuth a about it. The product midpoint rule over the
// given breakpoints (degrees) subdivided; the radial measure sin r dr is integrated exactly.
// `half` integrates azimuths 0…180° and doubles them (tables symmetric about the plane of
// incidence). The integrand f·cos θo vanishes at the horizon, so clipping cells there costs
// only a second-order error.
template <typename G>
void hemisphere(double theta_i_deg, const std::vector<double>& r_edges,
                const std::vector<double>& a_edges, bool half, G&& g) {
  const Vec3 wi = incidence(theta_i_deg);
  const auto frame = tab::MirrorFrame::of(wi);
  std::vector<double> a_mid, a_w;
  for (std::size_t k = 0; k + 1 < a_edges.size(); ++k) {
    a_mid.push_back(0.5 * (a_edges[k] + a_edges[k + 1]) * kDegToRad);
    a_w.push_back((a_edges[k + 1] - a_edges[k]) * kDegToRad * (half ? 2.0 : 1.0));
  }
  for (std::size_t j = 0; j + 1 < r_edges.size(); ++j) {
    const double r0 = r_edges[j] * kDegToRad, r1 = r_edges[j + 1] * kDegToRad;
    const double dmu = std::cos(r0) - std::cos(r1);
    const double rm = 0.5 * (r0 + r1);
    const double cr = std::cos(rm);
    for (std::size_t k = 0; k < a_mid.size(); ++k) {
      const Vec3 wo = frame.direction(cr, a_mid[k]);
      if (!(wo.z > 0)) continue;
      g(wi, wo, wo.z * dmu * a_w[k]);
    }
  }
}

std::vector<double> uniform(double a, double b, double step) {
  std::vector<double> v;
  const int n = static_cast<int>(std::ceil((b - a) / step - 1e-9));
  for (int i = 0; i <= n; ++i) v.push_back(a + (b - a) * i / n);
  return v;
}

// Breakpoints for a table: its own nodes where they are radial/azimuthal (specular tables),
// otherwise a list refined toward the specular direction, where tables are sharpest.
void table_edges(const BsdfTable& t, std::vector<double>& r, std::vector<double>& a, bool& half) {
  half = t.reduction().bilateral;
  if (t.param() == TableParam::specular) {
    r = t.axis(2);
    a = t.axis(3);
    if (r.front() > 0) r.insert(r.begin(), 0.0);
    if (r.back() < 180) r.push_back(180);
    if (a.front() > 0) a.insert(a.begin(), 0.0);
    const double end = half ? 180.0 : 360.0;
    if (a.back() < end) a.push_back(end);
    r = subdivide(r, 2, 0.5);
    a = subdivide(a, 2, 1.0);
  } else {
    r = subdivide({0, 0.5, 1, 2, 4, 8, 15, 30, 60, 90, 120, 150, 180}, 4, 0.25);
    a = uniform(0, half ? 180.0 : 360.0, 0.5);
  }
}

double channel_mean(std::span<const double> f) {
  return f.empty() ? 0.0 : std::accumulate(f.begin(), f.end(), 0.0) / static_cast<double>(f.size());
}

}  // namespace

std::vector<double> table_albedo(const BsdfTable& table, double theta_i_deg) {
  std::vector<double> sum(table.channels(), 0.0), f(table.channels());
  if (table.empty()) return sum;
  std::vector<double> r, a;
  bool half = false;
  table_edges(table, r, a, half);
  hemisphere(theta_i_deg, r, a, half, [&](const Vec3& wi, const Vec3& wo, double w) {
    table.eval(wi, wo, f);
    for (std::size_t c = 0; c < f.size(); ++c) sum[c] += w * f[c];
  });
  return sum;
}

std::vector<double> model_albedo(const Bsdf& model, double theta_i_deg,
                                 const std::vector<double>& radial_edges,
                                 const std::vector<double>& azimuth_edges) {
  std::vector<double> sum(model.channels(), 0.0), f(model.channels());
  // Isotropic models are symmetric about the plane of incidence; anisotropic ones are not,
  // so the whole circle is integrated (the edges then repeat mirrored).
  std::vector<double> a = azimuth_edges;
  for (std::size_t k = azimuth_edges.size(); k-- > 1;) a.push_back(360.0 - azimuth_edges[k - 1]);
  hemisphere(theta_i_deg, subdivide(radial_edges, 4, 0.5), subdivide(a, 2, 1.0), false,
             [&](const Vec3& wi, const Vec3& wo, double w) {
               model.eval(wi, wo, f);
               for (std::size_t c = 0; c < f.size(); ++c) sum[c] += w * f[c];
             });
  return sum;
}

std::vector<double> model_albedo(const Bsdf& model, double theta_i_deg) {
  return model_albedo(model, theta_i_deg,
                      {0, 0.25, 0.5, 1, 2, 3, 4, 6, 8, 10, 15, 20, 30, 45, 60, 90, 120, 150, 180},
                      uniform(0, 180, 5));
}

// ---- lobe-following grid --------------------------------------------------------------------

namespace {

struct Refiner {
  const Bsdf& model;
  std::vector<double> buf;

  // Channel-mean f at (θi, r, a) (degrees) and the cosine of wo; cos = −1 below the sample.
  double f(double theta_i, double r_deg, double a_deg, double& cos_o) {
    const Vec3 wi = incidence(theta_i);
    const Vec3 wo = tab::MirrorFrame::of(wi).direction(std::cos(r_deg * kDegToRad), a_deg * kDegToRad);
    cos_o = wo.z;
    if (!(wo.z > 1e-9)) {
      cos_o = -1;
      return 0;
    }
    model.eval(wi, wo, buf);
    return channel_mean(buf);
  }
};

// Splits the marked intervals of `axis` at their midpoints (none narrower than min_w).
bool split(std::vector<double>& axis, const std::vector<char>& mark, double min_w,
           std::size_t max_nodes) {
  std::vector<double> out{axis.front()};
  bool changed = false;
  for (std::size_t k = 0; k + 1 < axis.size(); ++k) {
    const double w = axis[k + 1] - axis[k];
    if (mark[k] && w >= 2 * min_w && axis.size() + (out.size() - k) < max_nodes) {
      out.push_back(std::round((axis[k] + 0.5 * w) * 1e4) / 1e4);
      changed = true;
    }
    out.push_back(axis[k + 1]);
  }
  axis = std::move(out);
  return changed;
}

}  // namespace

SpecularGrid lobe_grid(const Bsdf& model, const LobeGridOptions& o, LobeGridReport* report) {
  if (!(o.tolerance > 0 && o.tolerance <= 1)) throw Error::out_of_range("tolerance", o.tolerance, 0, 1);
  if (!(o.floor >= 0 && o.floor <= 1)) throw Error::out_of_range("floor", o.floor, 0, 1);
  if (!(o.energy_tolerance > 0 && o.energy_tolerance <= 1))
    throw Error::out_of_range("energy_tolerance", o.energy_tolerance, 0, 1);
  SpecularGrid g;
  g.theta_i = o.theta_i.empty() ? uniform(0, 85, 5) : o.theta_i;
  BsdfTable::check_axes(TableParam::specular, {g.theta_i, {}, {0}, {0}}, {true, false});
  g.radial = {0, 0.5, 1, 2, 3, 5, 7.5, 10, 15, 20, 30, 45, 60, 75, 90, 105, 120, 135, 150, 165, 180};
  if (!(o.azimuth_step >= 1 && o.azimuth_step <= 90))
    throw Error::out_of_range("azimuth_step", o.azimuth_step, 1, 90, " deg");
  g.azimuth = uniform(0, 180, o.azimuth_step);
  Refiner ref{model, std::vector<double>(model.channels())};
  double tol = o.tolerance;
  constexpr double kFracs[3] = {0.25, 0.5, 0.75};

  for (int energy_round = 0;; ++energy_round) {
    // 1. Refine radial and azimuthal nodes until linear interpolation along each axis, at
    //    a quarter, half and three quarters of every interval, is within tolerance of the
    //    model at every incidence angle.
    for (int round = 0; round < 40; ++round) {
      std::vector<char> mr(g.radial.size() - 1, 0), ma(g.azimuth.size() - 1, 0);
      for (const double ti : g.theta_i) {
        // Node values; an interval with an end below the sample plane holds the horizon
        // value there, and is left to the energy check.
        const std::size_t nr = g.radial.size();
        std::vector<double> node(nr * g.azimuth.size()), below(node.size());
        double peak = 0;  // of f·cos θo
        for (std::size_t k = 0; k < g.azimuth.size(); ++k)
          for (std::size_t j = 0; j < nr; ++j) {
            double c = 0;
            node[k * nr + j] = ref.f(ti, g.radial[j], g.azimuth[k], c);
            below[k * nr + j] = c < 0;
            peak = std::max(peak, node[k * nr + j] * std::max(c, 0.0));
          }
        // The error of f·cos θo — what a direction contributes to the reflected light —
        // relative to max(f·cos θo, floor × peak): near the horizon, where cos θo vanishes,
        // f need not be followed as closely.
        const double floor_abs = o.floor * peak;
        const auto bad = [&](double truth, double cos_o, double interp) {
          return cos_o > 0 &&
                 std::abs(interp - truth) * cos_o > tol * std::max(truth * cos_o, floor_abs);
        };
        for (std::size_t k = 0; k < g.azimuth.size(); ++k)
          for (std::size_t j = 0; j + 1 < nr; ++j) {
            if (mr[j] || below[k * nr + j] || below[k * nr + j + 1]) continue;
            const double v0 = node[k * nr + j], v1 = node[k * nr + j + 1];
            for (const double t : kFracs) {
              double c = 0;
              const double truth = ref.f(ti, g.radial[j] + t * (g.radial[j + 1] - g.radial[j]),
                                         g.azimuth[k], c);
              if (bad(truth, c, v0 + t * (v1 - v0))) {
                mr[j] = 1;
                break;
              }
            }
          }
        for (std::size_t j = 1; j < nr; ++j)
          for (std::size_t k = 0; k + 1 < g.azimuth.size(); ++k) {
            if (ma[k] || below[k * nr + j] || below[(k + 1) * nr + j]) continue;
            const double v0 = node[k * nr + j], v1 = node[(k + 1) * nr + j];
            for (const double t : kFracs) {
              double c = 0;
              const double truth = ref.f(ti, g.radial[j],
                                         g.azimuth[k] + t * (g.azimuth[k + 1] - g.azimuth[k]), c);
              if (bad(truth, c, v0 + t * (v1 - v0))) {
                ma[k] = 1;
                break;
              }
            }
          }
      }
      const bool cr = split(g.radial, mr, o.min_radial_step, o.max_nodes);
      const bool ca = split(g.azimuth, ma, o.min_azimuth_step, o.max_nodes);
      if (!cr && !ca) break;
    }

    // 2. Energy: the grey table's directional reflectance, integrated as readers
    //    interpolate it, against the model's — at every incidence node and halfway between
    //    them (where a missing incidence node shows).
    const BsdfTable grey = tabulate_specular(model, g, true);
    std::vector<double> radial_edges = g.radial, azimuth_edges = g.azimuth;
    std::vector<char> mi(g.theta_i.size() > 1 ? g.theta_i.size() - 1 : 0, 0);
    double worst = 0;
    char node_fail = 0;
    LobeGridReport rep;
    for (std::size_t i = 0; i < g.theta_i.size(); ++i) {
      for (int half_step = 0; half_step < 2; ++half_step) {
        if (half_step == 1 && i + 1 >= g.theta_i.size()) break;
        const double ti = half_step == 0 ? g.theta_i[i] : 0.5 * (g.theta_i[i] + g.theta_i[i + 1]);
        const double t = table_albedo(grey, ti)[0];
        const double m = channel_mean(model_albedo(model, ti, radial_edges, azimuth_edges));
        const double err = std::abs(t - m) / std::max(m, 1e-3);
        if (half_step == 0) {
          rep.theta_i.push_back(ti);
          rep.table.push_back(t);
          rep.model.push_back(m);
        }
        worst = std::max(worst, err);
        if (err > o.energy_tolerance) (half_step == 1 ? mi[i] : node_fail) = 1;
      }
    }
    rep.worst = worst;
    rep.tolerance = tol;
    if (report) *report = rep;
    if (worst <= o.energy_tolerance || energy_round >= 4) break;
    // Too far: add incidence nodes where the halfway check failed, and halve the
    // interpolation tolerance when a node itself failed.
    const bool more_ti = split(g.theta_i, mi, o.min_incidence_step, o.max_nodes);
    if (node_fail || !more_ti) tol *= 0.5;
  }
  return g;
}

BsdfTable tabulate_specular(const Bsdf& model, const SpecularGrid& g, bool grey) {
  BsdfTable::check_axes(TableParam::specular, {g.theta_i, {}, g.radial, g.azimuth}, {true, false},
                        grey ? 1 : model.channels());
  const std::size_t ch = model.channels(), out_ch = grey ? 1 : ch;
  std::vector<double> values;
  values.reserve(g.theta_i.size() * g.radial.size() * g.azimuth.size() * out_ch);
  std::vector<double> f(ch);
  std::vector<tab::MirrorFrame> frames;
  for (const double ti : g.theta_i) frames.push_back(tab::MirrorFrame::of(incidence(ti)));
  for (const double a : g.azimuth)
    for (const double r : g.radial)
      for (std::size_t i = 0; i < g.theta_i.size(); ++i) {
        const Vec3 wi = incidence(g.theta_i[i]);
        const Vec3 wo = frames[i].direction_above(r * kDegToRad, a * kDegToRad);
        model.eval(wi, wo, f);
        for (std::size_t c = 0; c < ch; ++c)
          if (!std::isfinite(f[c]) || f[c] < 0)
            throw Error(Errc::internal,
                        fmt::format("model '{}' gives f = {} at θi={:g}, radial {:g}, azimuth "
                                    "{:g}, channel {}", model.spec(), f[c], g.theta_i[i], r, a, c),
                        "tabulate");
        if (grey) values.push_back(channel_mean(f));
        else values.insert(values.end(), f.begin(), f.end());
      }
  return BsdfTable(TableParam::specular, {g.theta_i, {}, g.radial, g.azimuth},
                   grey ? std::vector<double>{} : model.wavelengths().values(), std::move(values),
                   {true, false});
}

std::vector<std::pair<Vec3, Vec3>> specular_grid_directions(const SpecularGrid& g) {
  std::vector<std::pair<Vec3, Vec3>> out;
  out.reserve(g.theta_i.size() * g.radial.size() * g.azimuth.size());
  for (const double a : g.azimuth)
    for (const double r : g.radial)
      for (const double ti : g.theta_i) {
        const Vec3 wi = incidence(ti);
        out.emplace_back(wi, tab::MirrorFrame::of(wi).direction_above(r * kDegToRad, a * kDegToRad));
      }
  return out;
}

std::vector<std::string> energy_warnings(const BsdfTable& table, bool transmission,
                                         std::span<const double> theta_i) {
  std::vector<std::string> out;
  for (const double ti : theta_i) {
    const auto a = table_albedo(table, ti);
    const auto it = std::max_element(a.begin(), a.end());
    if (it == a.end() || !(*it > 1 + 1e-3)) continue;
    const auto c = static_cast<std::size_t>(it - a.begin());
    out.push_back(fmt::format(
        "directional {} {:.4g} exceeds 1 at θi = {:g}°{}: the table reflects more light than "
        "falls on it", transmission ? "transmittance" : "reflectance", *it, ti,
        table.wavelengths().empty() ? std::string()
                                    : fmt::format(" ({:g} nm)", table.wavelengths()[c])));
  }
  return out;
}

}  // namespace gonio::twin
