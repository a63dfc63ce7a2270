// The glTF approximation of a BSDF: glTF parameters fitted to minimise CIEDE2000 between the
// material and the glTF reference BRDF (the twin's `gltf` model), rather than mapped by a
// formula, then checked on the studio render.
//
// Objective: Σ ΔE00² over a dense set of geometries (the solver's residuals are ΔE00's three
// signed terms, delta_e2000_terms), as a point light of unit irradiance shows
// them — θi every 10° to 80°, receivers about the specular direction at radial angles from
// 0° to 90° (dense near the peak) and five azimuths about it — each colour the displayed
// one of π f cos θi (clipped linear sRGB, CIELAB, as the sphere render displays a pixel).
// Geometries rather than the studio render itself: they are deterministic (the render's
// Monte Carlo noise would make the objective rough), a hundred times cheaper per
// evaluation, and cover the directions a sphere shows; the studio render then measures the
// result the way a person sees it (the figure the command prints and the targets use).
//
// Free: base colour (three ramps of rgb_spectrum), metallic, roughness, clearcoat and its
// roughness; ior is the material's own when it has one (a dielectric index is physical and
// glTF carries it exactly), else 1.5; specular stays 1. Levenberg–Marquardt (the fit
// family's solver) from two starts — a dielectric and a metal — the lower ΔE wins.
#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/color.hpp"
#include "gonio/twin/detail/fit/solver.hpp"
#include "gonio/twin/material.hpp"
#include "material/lobes.hpp"

namespace gonio::twin::material {
namespace {

// The colour weights of the renderer: white-aligned XYZ (spectrum_rgb's).
std::array<std::vector<double>, 3> xyz_weights_of(const WavelengthGrid& grid) {
  std::array<std::vector<double>, 3> w;
  for (auto& v : w) v.assign(grid.size(), 0.0);
  const Colorimeter cm(grid, Illuminant::get("D65"), Observer::get(ObserverKind::cie1931_2deg));
  const double wx = 0.3127 / 0.3290, wz = (1 - 0.3127 - 0.3290) / 0.3290;
  for (std::size_t c = 0; c < grid.size(); ++c) {
    w[0][c] = cm.weights()[c].x / cm.white().x * wx;
    w[1][c] = cm.weights()[c].y / cm.white().y;
    w[2][c] = cm.weights()[c].z / cm.white().z * wz;
  }
  return w;
}

struct Summary {
  std::vector<double> de;
  DeltaESummary stats() const {
    DeltaESummary s;
    s.samples = de.size();
    if (de.empty()) return s;
    auto v = de;
    std::sort(v.begin(), v.end());
    double sum = 0;
    for (const double x : v) sum += x;
    s.mean = sum / static_cast<double>(v.size());
    s.p95 = v[std::min(v.size() - 1, static_cast<std::size_t>(0.95 * static_cast<double>(v.size())))];
    s.max = v.back();
    return s;
  }
};

// The residuals the solver sees: ΔE00's three signed terms per pair (Σ of their squares is
// Σ ΔE00²), smooth where ΔE00 itself has a kink at 0.
std::vector<double> delta_e_terms(const std::vector<Lab>& a, const std::vector<Lab>& b) {
  std::vector<double> out;
  out.reserve(3 * a.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    for (const double t : delta_e2000_terms(a[i], b[i])) out.push_back(t);
  return out;
}

std::vector<double> delta_e(const std::vector<Lab>& a, const std::vector<Lab>& b) {
  std::vector<double> out(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) out[i] = delta_e2000(a[i], b[i]);
  return out;
}

// The material's own index of refraction, when a lobe has one.
double own_ior(const Bsdf& target) {
  try {
    for (const auto& l : canonical_lobes(target.spec(), target.wavelengths()))
      if (l.name == "plastic" || l.name == "coat" || l.name == "dielectric" || l.name == "gltf")
        return std::clamp(l.number("ior"), 1.0, 4.0);
  } catch (const Error&) {
    // a tabulated spec: no index
  }
  return 1.5;
}

GltfMaterial material_of(const std::vector<double>& x, double ior) {
  GltfMaterial m;
  m.base_color = {x[0], x[1], x[2]};
  m.metallic = x[3];
  m.roughness = x[4];
  m.clearcoat = x[5];
  m.clearcoat_roughness = x[6];
  m.ior = ior;
  return m;
}

}  // namespace

std::vector<GeometryPair> fit_geometries() {
  static const double kRadial[] = {0, 1, 2, 4, 7, 11, 16, 22, 30, 40, 55, 70, 90};
  std::vector<GeometryPair> out;
  for (int ti = 0; ti <= 80; ti += 10) {
    const double t = ti * kDegToRad;
    const Vec3 wi{-std::sin(t), 0, std::cos(t)};
    // About the specular direction s: e1 in the plane of incidence toward the normal, e2 across.
    const Vec3 s{std::sin(t), 0, std::cos(t)}, e1{-std::cos(t), 0, std::sin(t)}, e2{0, -1, 0};
    for (const double r : kRadial)
      for (int a = 0; a <= 180; a += 45) {
        if (r == 0 && a > 0) continue;
        const double rr = r * kDegToRad, aa = a * kDegToRad;
        const Vec3 wo = s * std::cos(rr) + (e1 * std::cos(aa) + e2 * std::sin(aa)) * std::sin(rr);
        if (wo.z < 0.1) continue;  // beyond 84°: the sphere's silhouette
        out.push_back({wi, wo});
      }
  }
  return out;
}

std::vector<Lab> geometry_colors(const Bsdf& b, const std::vector<GeometryPair>& pairs) {
  const auto w = xyz_weights_of(b.wavelengths());
  std::vector<double> f(b.channels());
  const RenderOptions display;
  std::vector<Lab> out;
  out.reserve(pairs.size());
  for (const auto& p : pairs) {
    b.eval(p.wi, p.wo, f);
    const double k = kPi * p.wi.z;
    Xyz xyz;
    for (std::size_t c = 0; c < f.size(); ++c) {
      xyz.x += w[0][c] * f[c] * k;
      xyz.y += w[1][c] * f[c] * k;
      xyz.z += w[2][c] * f[c] * k;
    }
    out.push_back(display_lab(display_rgb(xyz, display)));
  }
  return out;
}

GltfFit fit_gltf(const Bsdf& target, const GltfFitOptions& options) {
  const auto pairs = fit_geometries();
  const auto reference = geometry_colors(target, pairs);
  const auto& grid = target.wavelengths();
  const double ior = own_ior(target);

  fit::Problem problem;
  problem.params = {{"base_r", 0.5, 0, 1}, {"base_g", 0.5, 0, 1}, {"base_b", 0.5, 0, 1},
                    {"metallic", 0, 0, 1}, {"roughness", 0.5, 0.03, 1},
                    {"clearcoat", 0.05, 0, 1}, {"clearcoat_roughness", 0.3, 0.03, 1}};
  for (std::size_t j = 0; j < problem.params.size(); ++j) {
    problem.channel.push_back(-1);
    problem.group.push_back(static_cast<int>(j));
  }
  problem.channels = 1;
  problem.measured.assign(3 * pairs.size(), 0.0);
  problem.u.assign(3 * pairs.size(), 1.0);
  problem.evaluate = [&](const std::vector<double>& x, std::vector<double>& beta, std::vector<double>& se) {
    const auto model = make_bsdf(gltf_spec(material_of(x, ior)), grid);
    beta = delta_e_terms(reference, geometry_colors(*model, pairs));
    se.assign(beta.size(), 0.0);
  };
  FitOptions fo;
  fo.max_iterations = options.max_iterations;
  fo.tolerance = 1e-6;

  GltfFit best;
  double best_chi2 = std::numeric_limits<double>::infinity();
  const struct {
    const char* name;
    double metallic, roughness;
  } starts[] = {{"dielectric", 0.02, 0.5}, {"metal", 0.98, 0.3}};
  for (const auto& s : starts) {
    auto p = problem;
    p.params[3].start = s.metallic;
    p.params[4].start = s.roughness;
    const auto r = fit::solve(p, fo);
    if (!(r.chi2 < best_chi2)) continue;
    best_chi2 = r.chi2;
    std::vector<double> x;
    for (const auto& q : r.parameters) x.push_back(q.value);
    best.material = material_of(x, ior);
    best.iterations = r.iterations;
    best.start = s.name;
  }
  // The file gets the colours the fitted spectra have (linear sRGB), so that an RGB renderer
  // shows what the twin's `gltf` model of the spec shows.
  best.spec = gltf_spec(best.material);
  best.material = gltf_from_spec(best.spec, grid);
  const auto fitted = make_bsdf(best.spec, grid);
  best.geometries = Summary{delta_e(reference, geometry_colors(*fitted, pairs))}.stats();
  if (options.render_check) {
    const auto c = render_comparison({&target, fitted.get()}, {"material", "glTF approximation"}, options.check);
    const auto& stats = c.maps[0].stats;
    best.studio = DeltaESummary{stats.mean, stats.p95, stats.max, stats.pixels};
    best.studio_noise_mean = stats.noise_mean;
    if (!options.plot.empty()) write_png(c.image, options.plot);
  }
  return best;
}

}  // namespace gonio::twin::material
