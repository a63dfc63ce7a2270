// The twin's uncertainty budget (see budget.hpp).
#include "gonio/twin/budget.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <nlohmann/json.hpp>

namespace gonio::twin {
namespace {

// The finite-difference step of a tolerance: its half-width, or the half-width of the
// rectangle with the same u for a normal one (√3·u), so the variants stay within what the
// data sheet allows.
double step_of(const Tolerance& t) {
  return t.distribution == Distribution::normal ? std::sqrt(3.0) * t.u : t.half_width;
}

InstrumentProfile offset(InstrumentProfile p, double incidence, double receive) {
  p.arms.incidence_offset_deg += incidence;
  p.arms.receive_offset_deg += receive;
  return p;
}

InstrumentProfile scale_apertures(InstrumentProfile p, double source, double receiver) {
  p.source.aperture_deg.in_plane *= source;
  p.source.aperture_deg.perpendicular *= source;
  p.receiver.aperture_deg.in_plane *= receiver;
  p.receiver.aperture_deg.perpendicular *= receiver;
  return p;
}

std::vector<Twin> make_variants(const Twin& twin) {
  const auto& p = twin.profile();
  const double hi = step_of(p.incidence_arm_tolerance());
  const double hr = step_of(p.receive_arm_tolerance());
  const double hs = step_of(p.tolerances.source_aperture_rel);
  const double hd = step_of(p.tolerances.receiver_aperture_rel);
  std::vector<Twin> v;
  v.reserve(8);
  v.push_back(twin);
  v.push_back(twin.with_profile(offset(p, hi, 0)));
  v.push_back(twin.with_profile(offset(p, -hi, 0)));
  v.push_back(twin.with_profile(offset(p, 0, hr)));
  v.push_back(twin.with_profile(offset(p, 0, -hr)));
  v.push_back(twin.with_profile(scale_apertures(p, 1 + hs, 1)));
  v.push_back(twin.with_profile(scale_apertures(p, 1, 1 + hd)));
  v.push_back(twin.with_profile(offset(p, hi, hr)));
  return v;
}

// Var(c1·x + ½c2·x²) for a symmetric x with standard uncertainty u and kurtosis κ.
double contribution(double c1, double c2, double u, double kappa) {
  return std::sqrt(c1 * c1 * u * u + 0.25 * c2 * c2 * (kappa - 1) * u * u * u * u);
}

}  // namespace

BudgetModel::BudgetModel(const Twin& twin)
    : variants_(make_variants(twin)),
      incidence_(twin.profile().incidence_arm_tolerance()),
      receive_(twin.profile().receive_arm_tolerance()) {}

EstimatorOptions BudgetModel::variant_options(const EstimatorOptions& options, std::uint64_t samples) {
  EstimatorOptions o = options;
  // A fixed budget: the target is out of reach, so every variant traces the same paths.
  o.rel_se = 1e-6;
  o.abs_se = 0;
  o.max_samples = std::max<std::uint64_t>(1024, samples / 4);
  // The first round alone must fit the budget: R replicates × 2 paths (sample, white) ×
  // first_points, a power of two from 4.
  const auto per_point = 2 * static_cast<std::uint64_t>(std::max(1, o.replicates));
  std::uint64_t first = 4;
  while (first * 2 * per_point <= o.max_samples && first < 64) first *= 2;
  o.first_points = first;
  return o;
}

Budget BudgetModel::evaluate(const Prediction& nominal, const EstimatorOptions& options) const {
  const auto t0 = std::chrono::steady_clock::now();
  const auto& g = nominal.geometry;
  const auto opts = variant_options(options, nominal.samples);
  std::vector<std::vector<double>> beta;
  Budget b;
  beta.reserve(variants_.size());
  for (const auto& v : variants_) {
    auto p = v.predict(g, opts);
    b.samples += p.samples;
    beta.push_back(std::move(p.beta));
  }
  const auto& profile = nominal_profile();
  const auto& grid = nominal.wavelengths;
  const std::size_t C = grid.size();
  const auto& b0 = beta[0];

  const auto arm = [&](const char* name, const Tolerance& t, const std::vector<double>& plus,
                       const std::vector<double>& minus) {
    BudgetComponent c{name, "deg", t.distribution, false, {}, {}, {}, {}, {}, {}};
    const double h = step_of(t), u = t.standard_uncertainty();
    for (std::size_t k = 0; k < C; ++k) {
      const double c1 = h > 0 ? (plus[k] - minus[k]) / (2 * h) : 0;
      const double c2 = h > 0 ? (plus[k] - 2 * b0[k] + minus[k]) / (h * h) : 0;
      c.u.push_back(u);
      c.sensitivity.push_back(c1);
      c.curvature.push_back(c2);
      c.contribution.push_back(contribution(c1, c2, u, t.kurtosis()));
    }
    return c;
  };
  const auto aperture = [&](const char* name, const Tolerance& t, const std::vector<double>& plus) {
    BudgetComponent c{name, "1", t.distribution, false, {}, {}, {}, {}, {}, {}};
    const double h = step_of(t), u = t.standard_uncertainty();
    for (std::size_t k = 0; k < C; ++k) {
      const double c1 = h > 0 ? (plus[k] - b0[k]) / h : 0;
      c.u.push_back(u);
      c.sensitivity.push_back(c1);
      c.curvature.push_back(0);
      c.contribution.push_back(std::abs(c1) * u);
    }
    return c;
  };
  // β is proportional to the white's assigned value and inversely to the lamp's change
  // between the two readings: c = β (of the nominal prediction, the better estimate).
  const auto proportional = [&](const char* name, const Tolerance& t, bool random) {
    BudgetComponent c{name, "1", t.distribution, random, {}, {}, {}, {}, {}, {}};
    for (std::size_t k = 0; k < C; ++k) {
      const double u = t.standard_uncertainty(grid[k]);
      c.u.push_back(u);
      c.sensitivity.push_back(nominal.beta[k]);
      c.curvature.push_back(0);
      c.contribution.push_back(std::abs(nominal.beta[k]) * u);
    }
    return c;
  };

  b.components.push_back(arm("incidence_arm_deg", incidence_, beta[1], beta[2]));
  b.components.push_back(arm("receive_arm_deg", receive_, beta[3], beta[4]));
  {
    // The arms' interaction, (β(+,+) − β(+,0) − β(0,+) + β)/(h_i h_r), and its term of the
    // budget, c_ir² u_i² u_r² (GUM, JCGM 100:2008 §5.1.2, note).
    auto& rc = b.components[1];
    const double hi = step_of(incidence_), hr = step_of(receive_);
    const double ui = incidence_.standard_uncertainty(), ur = receive_.standard_uncertainty();
    rc.cross_with = "incidence_arm_deg";
    for (std::size_t k = 0; k < C; ++k) {
      const double cx = hi > 0 && hr > 0 ? (beta[7][k] - beta[1][k] - beta[3][k] + b0[k]) / (hi * hr) : 0;
      rc.cross.push_back(cx);
      rc.contribution[k] = std::sqrt(rc.contribution[k] * rc.contribution[k] + cx * cx * ui * ui * ur * ur);
    }
  }
  {
    // Each move lands within ±repeatability of where the arm's offset puts it: the same
    // sensitivities as the offsets, independent per arm and per point.
    const auto& t = profile.tolerances.arm_repeatability_deg;
    const double u = t.standard_uncertainty();
    BudgetComponent c{"arm_repeatability_deg", "deg", t.distribution, true, {}, {}, {}, {}, {}, {}};
    const auto& ci = b.components[0];
    const auto& cr = b.components[1];
    for (std::size_t k = 0; k < C; ++k) {
      const double a = contribution(ci.sensitivity[k], ci.curvature[k], u, t.kurtosis());
      const double r = contribution(cr.sensitivity[k], cr.curvature[k], u, t.kurtosis());
      c.u.push_back(u);
      c.sensitivity.push_back(std::hypot(ci.sensitivity[k], cr.sensitivity[k]));
      c.curvature.push_back(0);
      c.contribution.push_back(std::hypot(a, r));
    }
    b.components.push_back(std::move(c));
  }
  b.components.push_back(aperture("source_aperture_rel", profile.tolerances.source_aperture_rel, beta[5]));
  b.components.push_back(aperture("receiver_aperture_rel", profile.tolerances.receiver_aperture_rel, beta[6]));
  b.components.push_back(proportional("reference_white_rel", profile.tolerances.reference_white_rel, false));
  b.components.push_back(proportional("lamp_stability_rel", profile.tolerances.lamp_stability_rel, true));

  b.u_model.assign(C, 0.0);
  b.u_random.assign(C, 0.0);
  for (const auto& c : b.components)
    for (std::size_t k = 0; k < C; ++k) {
      const double s = c.contribution[k] * c.contribution[k];
      b.u_model[k] += s;
      if (c.random) b.u_random[k] += s;
    }
  for (std::size_t k = 0; k < C; ++k) {
    b.u_model[k] = std::sqrt(b.u_model[k]);
    b.u_random[k] = std::sqrt(b.u_random[k]);
  }
  b.beta_base = beta[0];
  b.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return b;
}

void to_json(nlohmann::json& j, const BudgetComponent& c) {
  const bool uniform =
      std::all_of(c.u.begin(), c.u.end(), [&](double v) { return c.u.empty() || v == c.u.front(); });
  j = nlohmann::json{{"component", c.name},
                     {"distribution", to_text(c.distribution)},
                     {"unit", c.unit},
                     {"random", c.random},
                     {"u", uniform ? nlohmann::json(c.u.empty() ? 0.0 : c.u.front()) : nlohmann::json(c.u)},
                     {"sensitivity", c.sensitivity},
                     {"contribution", c.contribution}};
}

void to_json(nlohmann::json& j, const Budget& b) {
  j = nlohmann::json{{"components", b.components}, {"u_model", b.u_model}};
}

}  // namespace gonio::twin
