// Divergence tests between measured and predicted spectra (see divergence.hpp).
#include "gonio/daemon/instrument/divergence.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <numeric>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio::daemon {
namespace {

constexpr double kMaxZ = 1e6;

using Xyz = twin::Xyz;

// CIE 1976 UCS: u′ = 4X/(X + 15Y + 3Z), v′ = 9Y/(X + 15Y + 3Z) (CIE 15:2004 §8.1).
std::array<double, 2> uv(const Xyz& c) {
  const double d = c.x + 15 * c.y + 3 * c.z;
  if (!(d > 0)) return {0, 0};
  return {4 * c.x / d, 9 * c.y / d};
}

// A scalar function of the two colours, with its standard uncertainty propagated to first
// order (GUM §5.1.2) from the spectra's: the gradient in XYZ by central differences, then the
// linear map XYZ = Σ w_k β_k. Measured channels are independent; the prediction's are
// independent for its Monte Carlo error and correlated through each budget component.
struct Propagated {
  double value = 0, u = 0;
};

Propagated propagate(const std::function<double(const Xyz&, const Xyz&)>& f, const Xyz& xm, const Xyz& xp,
                     const std::vector<Xyz>& w, const Spectrum& m, const Spectrum& p,
                     const std::vector<BudgetEntry>& budget, const std::vector<double>& u_model) {
  Propagated out;
  out.value = f(xm, xp);
  // ∂f/∂X, ∂f/∂Y, ∂f/∂Z for each colour; steps relative to Y.
  const double h = 1e-4 * std::max({xm.y, xp.y, 1e-3});
  const auto grad = [&](bool measured) {
    std::array<double, 3> g{};
    for (int a = 0; a < 3; ++a) {
      Xyz lo = measured ? xm : xp, hi = lo;
      double* pl = a == 0 ? &lo.x : a == 1 ? &lo.y : &lo.z;
      double* ph = a == 0 ? &hi.x : a == 1 ? &hi.y : &hi.z;
      *pl -= h;
      *ph += h;
      g[static_cast<std::size_t>(a)] = measured ? (f(hi, xp) - f(lo, xp)) / (2 * h) : (f(xm, hi) - f(xm, lo)) / (2 * h);
    }
    return g;
  };
  const auto gm = grad(true), gp = grad(false);
  const auto along = [&](const std::array<double, 3>& g, std::size_t k) {
    return g[0] * w[k].x + g[1] * w[k].y + g[2] * w[k].z;
  };
  double var = 0;
  const std::size_t C = m.size();
  for (std::size_t k = 0; k < C; ++k) {
    const double um = k < m.std_uncertainty.size() ? m.std_uncertainty[k] : 0;
    const double sp = k < p.std_uncertainty.size() ? p.std_uncertainty[k] : 0;
    var += std::pow(along(gm, k) * um, 2) + std::pow(along(gp, k) * sp, 2);
  }
  if (!budget.empty()) {
    for (const auto& b : budget) {
      if (b.contribution.size() != C) continue;
      double s = 0;
      for (std::size_t k = 0; k < C; ++k) {
        const double sign = k < b.sensitivity.size() && b.sensitivity[k] < 0 ? -1.0 : 1.0;
        s += along(gp, k) * sign * b.contribution[k];
      }
      var += s * s;
    }
  } else if (u_model.size() == C) {
    for (std::size_t k = 0; k < C; ++k) var += std::pow(along(gp, k) * u_model[k], 2);
  }
  out.u = std::sqrt(var);
  return out;
}

ColorCheck color_check(const Spectrum& m, const Spectrum& p, const std::vector<double>& u_model,
                         const std::vector<BudgetEntry>& budget, double tolerance,
                         const twin::Colorimeter& cm, const DivergenceSettings& s) {
  const auto& w = cm.weights();
  const auto xm = cm.xyz(m.values), xp = cm.xyz(p.values);
  const auto& white = cm.white();
  ColorCheck c;
  const double top = std::max(*std::max_element(m.values.begin(), m.values.end()),
                              *std::max_element(p.values.begin(), p.values.end()));
  if (top <= 1.0) {
    // CIELAB is defined for surface colours up to the perfect diffuser (L* ≤ 100).
    const auto de = propagate(
        [&](const Xyz& a, const Xyz& b) {
          return twin::delta_e2000(twin::xyz_to_lab(a, white), twin::xyz_to_lab(b, white));
        },
        xm, xp, w, m, p, budget, u_model);
    c.kind = "ciede2000";
    c.difference = de.value;
    c.u = de.u;
    c.limit = s.delta_e_threshold;
    c.decision = to_text(decide(de.value, de.u, c.limit, s.coverage_k));
    return c;
  }
  // Above the diffuser's luminance: chromaticity and luminance apart.
  const auto duv = propagate(
      [](const Xyz& a, const Xyz& b) {
        const auto ua = uv(a), ub = uv(b);
        return std::hypot(ua[0] - ub[0], ua[1] - ub[1]);
      },
      xm, xp, w, m, p, budget, u_model);
  const auto ratio = propagate([](const Xyz& a, const Xyz& b) { return b.y > 0 ? a.y / b.y : 0.0; }, xm,
                               xp, w, m, p, budget, u_model);
  c.kind = "chromaticity";
  c.difference = duv.value;
  c.u = duv.u;
  c.limit = s.delta_uv_threshold;
  c.luminance_ratio = ratio.value;
  c.luminance_u = ratio.u;
  const auto d = worse(decide(duv.value, duv.u, c.limit, s.coverage_k),
                       decide(ratio.value - 1, ratio.u, tolerance, s.coverage_k));
  c.decision = to_text(d);
  return c;
}

}  // namespace

Decision worse(Decision a, Decision b) { return static_cast<int>(a) >= static_cast<int>(b) ? a : b; }

Decision decide(double d, double u, double limit, double k) {
  const double a = std::abs(d);
  if (a - k * u > limit) return Decision::out_of_tolerance;
  if (a + k * u <= limit) return Decision::agrees;
  return Decision::undecided;
}

PointDivergence evaluate_point(const Spectrum& m, const Spectrum& p, const std::vector<double>& u_model,
                               const std::vector<BudgetEntry>& budget, double tolerance,
                               const twin::Colorimeter* colorimeter, const DivergenceSettings& s) {
  if (m.size() != p.size() || !(m.wavelengths == p.wavelengths))
    throw Error(Errc::internal, fmt::format("divergence: measured ({} channels) and predicted ({} "
                                            "channels) are on different grids",
                                            m.size(), p.size()));
  PointDivergence d;
  Decision spectral = Decision::agrees;
  for (std::size_t c = 0; c < m.size(); ++c) {
    const double um = m.std_uncertainty[c], up = p.std_uncertainty[c];
    const double ud = c < u_model.size() ? u_model[c] : 0;
    const double uc = std::sqrt(um * um + up * up + ud * ud);
    const double diff = m.values[c] - p.values[c];
    // Both exact and equal: agreement; exact and different: as unlikely as it gets (kept
    // finite, JSON has no infinity).
    const double z = uc > 0 ? std::min(std::abs(diff) / uc, kMaxZ) : (diff == 0 ? 0.0 : kMaxZ);
    if (z > d.z_max || c == 0) {
      d.z_max = z;
      d.worst_channel = c;
    }
    spectral = worse(spectral, decide(diff, uc, tolerance * std::abs(p.values[c]), s.coverage_k));
  }
  d.decision = spectral;
  if (colorimeter) {
    d.color = color_check(m, p, u_model, budget, tolerance, *colorimeter, s);
    if (d.color->kind == "ciede2000") d.delta_e00 = d.color->difference;
    d.decision = worse(d.decision, from_text<Decision>(d.color->decision).value_or(Decision::undecided));
  }
  d.diverged = d.decision == Decision::out_of_tolerance;
  d.inconsistent = d.z_max > s.z_threshold;
  return d;
}

std::shared_ptr<const twin::Colorimeter> colorimeter_for(const WavelengthGrid& grid) {
  try {
    return std::make_shared<const twin::Colorimeter>(grid);
  } catch (const Error&) {
    return nullptr;  // no overlap with the visible tables, or colord-data missing
  }
}

std::optional<double> reference_drift(const std::vector<double>& baseline,
                                      const std::vector<double>& current) {
  if (baseline.empty() || baseline.size() != current.size()) return std::nullopt;
  const double b = std::accumulate(baseline.begin(), baseline.end(), 0.0);
  const double c = std::accumulate(current.begin(), current.end(), 0.0);
  if (!(b > 0)) return std::nullopt;
  return std::abs(c / b - 1.0);
}

}  // namespace gonio::daemon
