// study_design — an adaptive scan against the uniform grid, on a virtual sample.
//
// The loop is goniod's (daemon/src/adaptive_loop.cpp): the choice of point k + 1 is made
// while point k is measured, from the points before it, so the study's point counts and
// times are the ones an instrument would see.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/design.hpp"
#include "gonio/twin/twin.hpp"

namespace gonio::twin {

namespace {

using Clock = std::chrono::steady_clock;

std::vector<Geometry> geometries_of(const std::vector<Geometry>& candidates, const std::vector<std::size_t>& chosen) {
  std::vector<Geometry> out;
  for (const auto c : chosen) out.push_back(candidates[c]);
  return out;
}

DesignRun run_adaptive(Design& design, const std::vector<MeasuredPoint>& readings, int max_points,
                       const ScanTiming& timing) {
  DesignRun run;
  const auto seeds = design.seeds();
  const auto cap = static_cast<std::size_t>(max_points);
  std::optional<std::size_t> current = seeds.empty() ? std::optional<std::size_t>{} : seeds.front();
  constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  std::size_t unadded = kNone;  // measured, not yet given to the design
  const auto catch_up = [&] {
    if (unadded == kNone) return;
    design.add(unadded, readings[unadded]);
    design.update();
    unadded = kNone;
  };
  while (current) {
    // What goniod computes while the arms serve `current`.
    auto t0 = Clock::now();
    catch_up();
    std::optional<std::size_t> next;
    const auto k = run.chosen.size();
    if (k + 1 < seeds.size()) next = seeds[k + 1];
    else if (k + 1 < cap) next = design.next({*current}, design.candidates()[*current]);
    run.choice_seconds_max = std::max(run.choice_seconds_max, std::chrono::duration<double>(Clock::now() - t0).count());
    run.chosen.push_back(*current);  // measured
    unadded = *current;
    if (k + 1 >= cap) break;
    if (!next) {
      // Nothing to choose before this point's reading: take it in, then ask again (the
      // arms wait for this one refit).
      catch_up();
      if (design.target_reached()) break;
      t0 = Clock::now();
      next = design.next({}, design.candidates()[*current]);
      run.choice_seconds_max = std::max(run.choice_seconds_max, std::chrono::duration<double>(Clock::now() - t0).count());
    }
    current = next;
  }
  catch_up();
  run.status = design.status();
  if (run.status.state != DesignState::target_reached && run.chosen.size() >= cap)
    run.status.state = DesignState::max_points;
  const auto& cand = design.candidates();
  run.seconds = run.chosen.empty() ? 0 : timing.total_s(cand[run.chosen.front()], geometries_of(cand, run.chosen));
  return run;
}

// The u of each candidate's reading per channel: the stated model, or the u the instrument
// had at that geometry (options.noise_of).
std::vector<std::vector<double>> noise_per_candidate(const std::vector<Geometry>& candidates, const WavelengthGrid& grid,
                                                     const std::vector<Prediction>& truth,
                                                     const DesignStudyOptions& options) {
  std::vector<std::vector<double>> u(candidates.size(), std::vector<double>(grid.size()));
  for (std::size_t c = 0; c < candidates.size(); ++c) {
    if (!options.noise_of) {
      for (std::size_t k = 0; k < grid.size(); ++k)
        u[c][k] = std::hypot(options.noise_rel * truth[c].beta[k], options.noise_abs);
      continue;
    }
    const auto& m = *options.noise_of;
    const auto at = std::find_if(m.points.begin(), m.points.end(), [&](const MeasuredPoint& p) {
      return std::abs(p.geometry.theta_i - candidates[c].theta_i) < 1e-6 &&
             std::abs(p.geometry.theta_r - candidates[c].theta_r) < 1e-6 &&
             std::abs(p.geometry.phi_i - candidates[c].phi_i) < 1e-6 &&
             std::abs(p.geometry.phi_r - candidates[c].phi_r) < 1e-6;
    });
    if (at == m.points.end())
      throw Error::invalid("noise_of", fmt::format("{} has no point at candidate {} ({})", m.source, c,
                                                   candidates[c].to_string()));
    u[c] = m.wavelengths == grid ? at->u : interpolate_linear(m.wavelengths.values(), at->u, grid.values());
  }
  return u;
}

}  // namespace

DesignStudy study_design(const std::string& model, const std::vector<Geometry>& candidates,
                         const WavelengthGrid& grid, const InstrumentProfile& profile,
                         const DesignStudyOptions& options) {
  const int per = model.empty() ? 1 : options.parameters.max_readings;
  const auto most = static_cast<double>(candidates.size()) * per;
  if (options.max_points < 1 || options.max_points > most) throw Error::out_of_range("max_points", options.max_points, 1, most);
  if (!(options.noise_rel >= 0 && options.noise_rel <= 1)) throw Error::out_of_range("noise_rel", options.noise_rel, 0, 1);
  if (!(options.noise_abs > 0 && options.noise_abs <= 1)) throw Error::out_of_range("noise_abs", options.noise_abs, 0, 1);
  const bool parameters = !model.empty();
  // What goniod would accept: every candidate within the arms' reach, and only moves the
  // motion guard allows, from the seeds on.
  const ArmReach reach(profile);
  reach.check(candidates);
  const auto movable = [arms = reach.clearance](const Geometry& a, const Geometry& b) {
    return arms.can_move(a, b);
  };
  std::string truth = options.truth;
  if (truth.empty()) {
    if (!parameters) throw Error::invalid("truth", "is required in curve mode (the virtual sample)");
    const ModelTemplate tmpl(model, grid);
    std::vector<double> x;
    for (const auto& p : tmpl.parameters()) x.push_back(p.start);
    truth = tmpl.spec(x);
  }
  // The virtual sample on every candidate, then one noisy reading each (seeded per
  // candidate, so both runs read the same value where they measure the same geometry).
  const Twin twin(profile, make_bsdf(truth, grid), grid);
  const auto pred = twin.predict_many(candidates, options.measurement, options.parameters.threads);
  const auto noise = noise_per_candidate(candidates, grid, pred, options);
  std::vector<MeasuredPoint> readings(candidates.size());
  for (std::size_t c = 0; c < candidates.size(); ++c) {
    std::mt19937_64 rng(options.seed * 0x9E3779B97F4A7C15ull + c);
    std::normal_distribution<double> normal;
    auto& r = readings[c];
    r.geometry = candidates[c];
    for (std::size_t k = 0; k < grid.size(); ++k) {
      const double b = pred[c].beta[k];
      const double u = noise[c][k];
      r.beta.push_back(b + u * normal(rng));
      r.u.push_back(u);
    }
  }

  DesignStudy out;
  const auto& timing = parameters ? options.parameters.timing : options.curve.timing;
  for (std::size_t c = 0; c < candidates.size(); ++c) out.uniform.chosen.push_back(c);
  out.uniform.seconds = timing.total_s(candidates.front(), candidates);
  out.uniform.status.mode = parameters ? AdaptiveMode::parameters : AdaptiveMode::curve;
  out.uniform.status.points_used = candidates.size();
  out.uniform.status.state = DesignState::max_points;

  if (parameters) {
    MeasuredData all;
    all.wavelengths = grid;
    all.points = readings;
    all.source = "uniform grid";
    auto f = options.parameters.fit;
    f.naive = false;
    const auto fit = fit_material(all, model, profile, f);
    for (const auto& p : fit.parameters) out.uniform.status.parameters.push_back({p.name, p.value, p.u});
    out.uniform.status.chi2_per_dof = fit.chi2_per_dof;
    ParameterDesign design(model, candidates, grid, profile, options.parameters);
    design.set_movable(movable);
    out.adaptive = run_adaptive(design, readings, options.max_points, timing);
  } else {
    out.uniform.status.estimated_error = 0;
    CurveDesign design(candidates, options.curve);
    design.set_movable(movable);
    out.adaptive = run_adaptive(design, readings, options.max_points, timing);
    double vs_dense = 0, vs_truth = 0;
    const double k = options.curve.coverage_k;
    std::vector<double> peak(grid.size(), 0.0);
    for (const auto& p : pred)
      for (std::size_t ch = 0; ch < peak.size(); ++ch) peak[ch] = std::max(peak[ch], p.beta[ch]);
    for (std::size_t c = 0; c < candidates.size(); ++c) {
      const auto in = design.interpolate(c);
      if (in.empty()) {
        vs_dense = vs_truth = std::numeric_limits<double>::infinity();
        continue;
      }
      for (std::size_t ch = 0; ch < in.size(); ++ch) {
        const double t = pred[c].beta[ch], d = readings[c].beta[ch];
        const double u = noise[c][ch];
        const double scale = std::max(std::abs(t), options.curve.floor * peak[ch]);
        vs_truth = std::max(vs_truth, std::max(0.0, std::abs(in[ch] - t) - k * u) / scale);
        vs_dense = std::max(vs_dense, std::max(0.0, std::abs(in[ch] - d) - k * std::sqrt(2.0) * u) / scale);
      }
    }
    out.error_vs_dense = vs_dense;
    out.error_vs_truth = vs_truth;
  }
  return out;
}

nlohmann::json DesignStudy::to_json(const std::vector<Geometry>& candidates) const {
  const auto run = [&](const DesignRun& r) {
    auto geoms = nlohmann::json::array();
    for (const auto c : r.chosen) geoms.push_back(candidates[c].to_string());
    return nlohmann::json{{"points", r.chosen.size()},
                          {"seconds", r.seconds},
                          {"status", r.status.to_json()},
                          {"choice_seconds_max", r.choice_seconds_max},
                          {"geometries", std::move(geoms)}};
  };
  nlohmann::json j{{"uniform", run(uniform)}, {"adaptive", run(adaptive)}};
  j["uniform"].erase("geometries");
  j["points_ratio"] = static_cast<double>(adaptive.chosen.size()) / static_cast<double>(uniform.chosen.size());
  j["time_ratio"] = uniform.seconds > 0 ? adaptive.seconds / uniform.seconds : 0.0;
  if (error_vs_dense) j["error_vs_dense"] = *error_vs_dense;
  if (error_vs_truth) j["error_vs_truth"] = *error_vs_truth;
  return j;
}

}  // namespace gonio::twin
