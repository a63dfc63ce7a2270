#include "cli/output.hpp"

#include <cmath>

#include <fmt/format.h>
#include <fmt/ostream.h>

namespace gonio::twin::cli {

int& exit_code() {
  static int code = 0;
  return code;
}

double channel_mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / static_cast<double>(v.size());
}

nlohmann::json prediction_json(const Prediction& p) {
  nlohmann::json diag = {{"sampling", to_text(p.diagnostics.sampling)},
                         {"mean_theta_i", p.diagnostics.mean_theta_i},
                         {"mean_theta_r", p.diagnostics.mean_theta_r},
                         {"converged", p.diagnostics.converged}};
  // NaN is not JSON: the baseline estimator cannot tell the seen fraction.
  if (std::isnan(p.diagnostics.seen_fraction))
    diag["seen_fraction"] = nullptr;
  else
    diag["seen_fraction"] = p.diagnostics.seen_fraction;
  return {{"geometry", p.geometry},
          {"wavelengths_nm", p.wavelengths.values()},
          {"radiance_factor", p.beta},
          {"std_error", p.std_error},
          {"samples", p.samples},
          {"seconds", p.seconds},
          {"diagnostics", diag}};
}

nlohmann::json predictions_json(const std::vector<Prediction>& ps) {
  auto arr = nlohmann::json::array();
  for (const auto& p : ps) arr.push_back(prediction_json(p));
  return arr;
}

void write_predictions_csv(std::ostream& out, const std::vector<Prediction>& ps) {
  out << "theta_i,phi_i,theta_r,phi_r,wavelength_nm,radiance_factor,std_error\n";
  for (const auto& p : ps)
    for (std::size_t c = 0; c < p.beta.size(); ++c)
      fmt::print(out, "{},{},{},{},{},{:.9g},{:.3g}\n", p.geometry.theta_i, p.geometry.phi_i,
                 p.geometry.theta_r, p.geometry.phi_r, p.wavelengths[c], p.beta[c],
                 p.std_error[c]);
}

void write_predictions_table(std::ostream& out, const std::vector<Prediction>& ps) {
  fmt::print(out, "{:>16}  {:>12}  {:>10}  {:>7}  {:>6}  {:>10}  {:>8}\n", "geometry",
             "β (mean λ)", "s.e.", "rel", "seen", "samples", "ms");
  for (const auto& p : ps) {
    const double b = channel_mean(p.beta);
    // Channels share their paths, so their errors are correlated: the mean of the
    // per-channel errors bounds the error of the channel mean.
    const double se = channel_mean(p.std_error);
    const auto seen = std::isnan(p.diagnostics.seen_fraction)
                          ? std::string("-")
                          : fmt::format("{:.1f}%", 100 * p.diagnostics.seen_fraction);
    fmt::print(out, "{:>16}  {:>12.6g}  {:>10.3g}  {:>6.3f}%  {:>6}  {:>10}  {:>8.2f}{}\n",
               p.geometry.to_string(), b, se, b != 0 ? 100 * se / std::abs(b) : 0.0, seen,
               p.samples, 1e3 * p.seconds, p.diagnostics.converged ? "" : "  (budget reached)");
  }
  if (ps.size() == 1) {
    const auto& p = ps.front();
    fmt::print(out, "\n{:>8}  {:>12}  {:>10}\n", "λ (nm)", "β", "s.e.");
    for (std::size_t c = 0; c < p.beta.size(); ++c)
      fmt::print(out, "{:>8g}  {:>12.6g}  {:>10.3g}\n", p.wavelengths[c], p.beta[c], p.std_error[c]);
  }
}

void write_budget_table(std::ostream& out, const std::vector<Prediction>& ps,
                        const std::vector<Budget>& budgets) {
  for (std::size_t i = 0; i < ps.size(); ++i) {
    const auto& p = ps[i];
    const auto& b = budgets[i];
    std::size_t k = 0;
    for (std::size_t c = 1; c < p.beta.size(); ++c)
      if (p.beta[c] > p.beta[k]) k = c;
    const double beta = p.beta[k];
    const auto rel = [&](double u) { return beta != 0 ? 100 * u / std::abs(beta) : 0.0; };
    fmt::print(out, "{}  at {:g} nm: β = {:.6g}\n", p.geometry.to_string(), p.wavelengths[k], beta);
    fmt::print(out, "  {:<24} {:<12} {:>11} {:>6} {:>13} {:>12} {:>8}  {}\n", "input quantity",
               "distribution", "u(x)", "unit", "c = ∂β/∂x", "u_x(β)", "rel", "");
    for (const auto& c : b.components) {
      const auto dist = to_text(c.distribution);
      fmt::print(out, "  {:<24} {:<12} {:>11.4g} {:>6} {:>13.4g} {:>12.4g} {:>7.3f}%  {}\n", c.name,
                 dist, c.u[k], c.unit, c.sensitivity[k], c.contribution[k], rel(c.contribution[k]),
                 c.random ? "random" : "systematic");
    }
    const double se = p.std_error[k], um = b.u_model[k];
    const double uc = std::hypot(se, um);
    fmt::print(out, "  {:<24} {:<12} {:>11} {:>6} {:>13} {:>12.4g} {:>7.3f}%\n", "twin (Monte Carlo)",
               "normal", "", "", "", se, rel(se));
    fmt::print(out, "  {:<24} {:>59.4g} {:>7.3f}%\n", "u_model", um, rel(um));
    fmt::print(out, "  {:<24} {:>59.4g} {:>7.3f}%\n", "u_c (combined)", uc, rel(uc));
    fmt::print(out, "  {:<24} {:>59.4g} {:>7.3f}%\n\n", "U (k = 2)", 2 * uc, rel(2 * uc));
  }
}

}  // namespace gonio::twin::cli
