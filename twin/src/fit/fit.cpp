// fit_material and calibrate: the virtual measurement as the model of a weighted
// least-squares problem (method: twin/fitting.md), the naive counterpart at the nominal
// directions, the instrument-corrected table and the JSON form of the result.
#include "gonio/twin/fit.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <tuple>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/twin/detail/core/estimator.hpp"
#include "gonio/twin/detail/core/sobol.hpp"
#include "gonio/twin/detail/fit/solver.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::twin {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// The distinct geometries of the data (repeats are measured once by the twin) and, per
// point, the index of its geometry.
struct Geometries {
  std::vector<Geometry> unique;
  std::vector<std::size_t> of_point;
};

Geometries distinct_geometries(const MeasuredData& data) {
  Geometries g;
  std::map<std::tuple<double, double, double, double>, std::size_t> seen;
  for (const auto& p : data.points) {
    const auto key = std::tuple{p.geometry.theta_i, p.geometry.phi_i, p.geometry.theta_r,
                                p.geometry.phi_r};
    auto [it, fresh] = seen.emplace(key, g.unique.size());
    if (fresh) g.unique.push_back(p.geometry);
    g.of_point.push_back(it->second);
  }
  return g;
}

fit::Problem base_problem(const MeasuredData& data) {
  fit::Problem p;
  p.channels = data.wavelengths.size();
  for (const auto& pt : data.points) {
    p.measured.insert(p.measured.end(), pt.beta.begin(), pt.beta.end());
    p.u.insert(p.u.end(), pt.u.begin(), pt.u.end());
  }
  return p;
}

// β and s.e. of every residual from one prediction per distinct geometry.
void scatter(const Geometries& geo, const std::vector<Prediction>& pred, double gain,
             const std::vector<double>* rho, std::vector<double>& beta, std::vector<double>& se) {
  beta.clear();
  se.clear();
  for (const std::size_t k : geo.of_point) {
    const auto& p = pred[k];
    const double s = gain * (rho ? (*rho)[k] : 1.0);
    for (std::size_t c = 0; c < p.beta.size(); ++c) {
      beta.push_back(s * p.beta[c]);
      se.push_back(std::abs(s) * p.std_error[c]);
    }
  }
}

// π f at the nominal directions, every channel.
std::vector<double> nominal_beta(const Bsdf& bsdf, const Geometry& g) {
  const auto a = g.incident_direction();
  const auto b = g.receiving_direction();
  std::vector<double> f(bsdf.channels());
  bsdf.eval({a[0], a[1], a[2]}, {b[0], b[1], b[2]}, f);
  for (double& v : f) v *= kPi;
  return f;
}

void check_grid(const MeasuredData& data) { data.validate(); }

// Starts the problem at a previous fit's values where they are identifiable and inside.
void start_from(fit::Problem& problem, const FitResult& previous) {
  for (std::size_t j = 0; j < problem.params.size(); ++j) {
    const auto& p = previous.parameters[j];
    auto& q = problem.params[j];
    if (!p.identifiable || p.at_bound || !std::isfinite(p.value)) continue;
    q.start = std::clamp(p.value, q.lo + 1e-3 * (q.hi - q.lo), q.hi - 1e-3 * (q.hi - q.lo));
  }
}

nlohmann::json number_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

// ---- calibration parameters ----------------------------------------------------------------

enum class CalParam { incidence_offset, receive_offset, sample_tilt, source_scale, receiver_scale, gain };

struct CalInfo {
  CalParam id;
  const char* name;
  double lo, hi;
  bool log;
};

const std::vector<CalInfo>& cal_table() {
  static const std::vector<CalInfo> t{
      {CalParam::incidence_offset, "incidence_offset_deg", -5, 5, false},
      {CalParam::receive_offset, "receive_offset_deg", -5, 5, false},
      {CalParam::sample_tilt, "sample_tilt_deg", -5, 5, false},
      {CalParam::source_scale, "source_aperture_scale", 0.2, 5, true},
      {CalParam::receiver_scale, "receiver_aperture_scale", 0.2, 5, true},
      {CalParam::gain, "gain", 0.5, 2, false},
  };
  return t;
}

struct CalValues {
  double incidence_offset = 0, receive_offset = 0, tilt = 0, source_scale = 1,
         receiver_scale = 1, gain = 1;
};

CalValues cal_values(const InstrumentProfile& base, const std::vector<CalParam>& ids,
                     const std::vector<double>& x) {
  CalValues v;
  v.incidence_offset = base.arms.incidence_offset_deg;
  v.receive_offset = base.arms.receive_offset_deg;
  for (std::size_t j = 0; j < ids.size(); ++j) {
    switch (ids[j]) {
      case CalParam::incidence_offset: v.incidence_offset = x[j]; break;
      case CalParam::receive_offset: v.receive_offset = x[j]; break;
      case CalParam::sample_tilt: v.tilt = x[j]; break;
      case CalParam::source_scale: v.source_scale = x[j]; break;
      case CalParam::receiver_scale: v.receiver_scale = x[j]; break;
      case CalParam::gain: v.gain = x[j]; break;
    }
  }
  return v;
}

// The instrument with the calibration values (the sample tilt not included).
InstrumentProfile corrected_profile(const InstrumentProfile& base, const CalValues& v) {
  auto p = base;
  p.arms.incidence_offset_deg = v.incidence_offset;
  p.arms.receive_offset_deg = v.receive_offset;
  p.source.aperture_deg.in_plane *= v.source_scale;
  p.source.aperture_deg.perpendicular *= v.source_scale;
  p.receiver.aperture_deg.in_plane *= v.receiver_scale;
  p.receiver.aperture_deg.perpendicular *= v.receiver_scale;
  p.reference_beta *= v.gain;
  return p;
}

// Reference white flux at a geometry through the instrument (channel mean over replicates),
// with a fixed budget and seed: the ratio of two such readings shares its random numbers.
double reference_flux(const InstrumentProfile& profile, const Bsdf& reference, const Geometry& g,
                      const FitOptions& o) {
  const auto setup = detail::make_setup(profile, g);
  detail::FluxEstimator est(setup, reference, nullptr, o.estimator, detail::mix64(o.seed ^ 0x7117),
                            o.replicates);
  est.run_until(256);
  double s = 0;
  for (int r = 0; r < o.replicates; ++r)
    for (std::size_t c = 0; c < est.channels(); ++c) s += est.sample_flux(r, c);
  return s;
}

}  // namespace

// ---- options ---------------------------------------------------------------------------------

void FitOptions::validate() const {
  if (samples < 1024 || samples > (1ull << 30))
    throw Error::out_of_range("samples", static_cast<double>(samples), 1024,
                              static_cast<double>(1ull << 30));
  if (replicates < 4 || replicates > 256) throw Error::out_of_range("replicates", replicates, 4, 256);
  if (max_iterations < 1 || max_iterations > 1000)
    throw Error::out_of_range("max_iterations", max_iterations, 1, 1000);
  if (starts < 0 || starts > 256) throw Error::out_of_range("starts", starts, 0, 256);
  if (!(misfit_limit >= 1 && misfit_limit <= 1e6))
    throw Error::out_of_range("misfit_limit", misfit_limit, 1, 1e6);
  if (!(tolerance > 0 && tolerance <= 0.1)) throw Error::out_of_range("tolerance", tolerance, 0, 0.1);
  if (!(correlation_limit > 0 && correlation_limit < 1))
    throw Error::out_of_range("correlation_limit", correlation_limit, 0, 1);
}

EstimatorOptions FitOptions::estimator_options() const {
  EstimatorOptions o;
  o.kind = estimator;
  o.rel_se = 1e-6;  // never reached: every evaluation spends the same fixed budget
  o.abs_se = 0;
  o.max_samples = samples;
  o.replicates = replicates;
  o.seed = seed;
  o.validate();
  return o;
}

// ---- material fit ----------------------------------------------------------------------------

FitResult fit_material(const MeasuredData& data, std::string_view model,
                       const InstrumentProfile& profile, const FitOptions& options) {
  const auto start = Clock::now();
  options.validate();
  profile.validate();
  check_grid(data);
  const auto& grid = data.wavelengths;
  const ModelTemplate tmpl(model, grid);
  const auto geo = distinct_geometries(data);
  const auto est = options.estimator_options();
  const auto reference = make_bsdf(profile.reference_bsdf, grid);

  auto problem = base_problem(data);
  problem.params = tmpl.parameters();
  problem.channel = tmpl.channel();
  if (!options.start.empty()) {
    if (options.start.size() != problem.params.size())
      throw Error::invalid("start", fmt::format("has {} values for {} free parameters",
                                                options.start.size(), problem.params.size()));
    for (std::size_t j = 0; j < problem.params.size(); ++j) {
      auto& q = problem.params[j];
      q.start = std::clamp(options.start[j], q.lo + 1e-3 * (q.hi - q.lo), q.hi - 1e-3 * (q.hi - q.lo));
    }
  }
  int group = -1;
  for (std::size_t j = 0; j < problem.params.size(); ++j) {
    if (problem.channel[j] <= 0) ++group;  // a per-channel mark is one group
    problem.group.push_back(group);
  }

  // The model at the nominal directions: the naive fit, the global start, and the whole fit
  // for data that are f at exact directions (tables).
  auto nominal = problem;
  nominal.evaluate = [&](const std::vector<double>& x, std::vector<double>& beta,
                         std::vector<double>& se) {
    const auto bsdf = make_bsdf(tmpl.spec(x), grid);
    std::vector<std::vector<double>> per(geo.unique.size());
    for (std::size_t k = 0; k < geo.unique.size(); ++k) per[k] = nominal_beta(*bsdf, geo.unique[k]);
    beta.clear();
    for (const std::size_t k : geo.of_point) beta.insert(beta.end(), per[k].begin(), per[k].end());
    se.assign(beta.size(), 0.0);
  };
  const auto starts = fit::global_start(nominal, options);
  for (std::size_t j = 0; j < starts.size(); ++j)
    nominal.params[j].start = problem.params[j].start = starts[j];

  const auto finish = [&](FitResult& r, const fit::Optimum& at, Clock::time_point t0) {
    r.kind = "fit";
    std::vector<double> x;
    for (const auto& p : r.parameters) x.push_back(p.value);
    r.spec = tmpl.spec(x);
    r.points = data.points.size();
    r.residuals = data.residuals();
    r.misfit = fit::misfit_regions(data, at);
    if (r.chi2_per_dof > options.misfit_limit) r.warnings.insert(r.warnings.begin(), fit::misfit_warning(r));
    r.seconds = seconds_since(t0);
  };

  if (data.exact_directions) {
    fit::Optimum at;
    auto r = fit::solve(nominal, options, &at);
    r.nominal_directions = true;
    finish(r, at, start);
    return r;
  }

  // The naive fit first: cheap, and its result is a good start for the instrument fit.
  std::vector<FitResult> naive;
  if (options.naive) {
    const auto t0 = Clock::now();
    fit::Optimum at;
    auto r = fit::solve(nominal, options, &at);
    r.nominal_directions = true;
    finish(r, at, t0);
    naive.push_back(std::move(r));
  }

  problem.evaluate = [&](const std::vector<double>& x, std::vector<double>& beta,
                         std::vector<double>& se) {
    const Twin twin(profile, make_bsdf(tmpl.spec(x), grid), reference, grid);
    scatter(geo, twin.predict_many(geo.unique, est, options.threads), 1.0, nullptr, beta, se);
  };
  // A Jacobian's stepped models on the paths of the model at x (Twin::predict_variants).
  problem.evaluate_steps = [&](const std::vector<std::vector<double>>& xs,
                               std::vector<std::vector<double>>& beta,
                               std::vector<std::vector<double>>& se) {
    const Twin twin(profile, make_bsdf(tmpl.spec(xs[0]), grid), reference, grid);
    std::vector<BsdfPtr> variants;
    for (std::size_t k = 1; k < xs.size(); ++k) variants.push_back(make_bsdf(tmpl.spec(xs[k]), grid));
    const auto pred = twin.predict_variants(geo.unique, variants, est, options.threads);
    beta.assign(xs.size(), {});
    se.assign(xs.size(), {});
    std::vector<Prediction> column(pred.size());
    for (std::size_t k = 0; k < xs.size(); ++k) {
      for (std::size_t g = 0; g < pred.size(); ++g) column[g] = pred[g][k];
      scatter(geo, column, 1.0, nullptr, beta[k], se[k]);
    }
  };
  // The naive optimum, when it converged inside the bounds, is a far better start than the
  // user's guess and costs no virtual measurement: the instrument fit starts there.
  if (!naive.empty() && naive.front().converged) start_from(problem, naive.front());
  fit::Optimum at;
  auto r = fit::solve(problem, options, &at);
  r.naive = std::move(naive);
  finish(r, at, start);
  return r;
}

// ---- calibration -----------------------------------------------------------------------------

const std::vector<std::string>& calibration_parameters() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& c : cal_table()) n.emplace_back(c.name);
    return n;
  }();
  return names;
}

namespace {

// The named calibration parameters appended to `problem`, each starting at the profile's
// value, kept just inside its range.
std::vector<CalParam> add_cal_parameters(fit::Problem& problem, const std::vector<std::string>& names,
                                         const InstrumentProfile& profile) {
  std::vector<CalParam> ids;
  for (std::size_t j = 0; j < names.size(); ++j) {
    const auto it = std::find_if(cal_table().begin(), cal_table().end(),
                                 [&](const CalInfo& c) { return names[j] == c.name; });
    if (it == cal_table().end()) {
      std::string allowed;
      for (const auto& c : cal_table()) allowed += (allowed.empty() ? "" : ", ") + std::string(c.name);
      throw Error::invalid(fmt::format("fit[{}]", j),
                           fmt::format("'{}' is not a calibration parameter (allowed: {})",
                                       names[j], allowed));
    }
    if (std::find(ids.begin(), ids.end(), it->id) != ids.end())
      throw Error::invalid(fmt::format("fit[{}]", j), fmt::format("'{}' is named twice", names[j]));
    ids.push_back(it->id);
    double s = it->id == CalParam::incidence_offset ? profile.arms.incidence_offset_deg
               : it->id == CalParam::receive_offset ? profile.arms.receive_offset_deg
               : it->id == CalParam::sample_tilt    ? 0.0
                                                    : 1.0;
    s = std::clamp(s, it->lo + 1e-3 * (it->hi - it->lo), it->hi - 1e-3 * (it->hi - it->lo));
    problem.params.push_back({it->name, s, it->lo, it->hi, it->log});
    problem.channel.push_back(-1);
    problem.group.push_back(static_cast<int>(j));
  }
  return ids;
}

// A calibration's result as such, with the profile it makes; returns the fitted values.
CalValues describe_calibration(FitResult& r, const MeasuredData& data, const Bsdf& sample,
                               const InstrumentProfile& profile, const std::vector<CalParam>& ids) {
  r.kind = "calibrate";
  r.spec = sample.spec();
  r.points = data.points.size();
  r.residuals = data.residuals();
  std::vector<double> x;
  for (const auto& p : r.parameters) x.push_back(p.value);
  const auto v = cal_values(profile, ids, x);
  r.profile = corrected_profile(profile, v);
  return v;
}

// Naive: an ideal instrument (no apertures, no footprints) with the arms where they are.
FitResult naive_calibration(fit::Problem np, const MeasuredData& data, const Bsdf& sample,
                            const InstrumentProfile& profile, const std::vector<CalParam>& ids,
                            const FitOptions& options) {
  const auto t0 = Clock::now();
  np.evaluate = [&](const std::vector<double>& x, std::vector<double>& beta,
                    std::vector<double>& se) {
    const auto v = cal_values(profile, ids, x);
    beta.clear();
    for (const auto& pt : data.points) {
      const auto& g = pt.geometry;
      const Geometry actual{g.theta_i + v.incidence_offset + v.tilt, g.phi_i,
                            g.theta_r + v.receive_offset - v.tilt, g.phi_r};
      auto b = nominal_beta(sample, actual);
      // A tilted sample intercepts the whole beam; its radiance is seen at θr − τ.
      const double c0 = std::cos((g.theta_r + v.receive_offset) * kDegToRad);
      const double ratio = c0 != 0 ? std::cos(actual.theta_r * kDegToRad) / c0 : 1.0;
      for (double& x_ : b) beta.push_back(x_ * v.gain * profile.reference_beta * ratio);
    }
    se.assign(beta.size(), 0.0);
  };
  auto r = fit::solve(np, options);
  describe_calibration(r, data, sample, profile, ids);
  r.seconds = seconds_since(t0);
  return r;
}

}  // namespace

FitResult calibrate(const MeasuredData& data, std::string_view sample_spec,
                    const std::vector<std::string>& names, const InstrumentProfile& profile,
                    const FitOptions& options) {
  const auto start = Clock::now();
  options.validate();
  profile.validate();
  check_grid(data);
  if (names.empty()) throw Error::invalid("fit", "name at least one instrument parameter to fit");
  if (data.exact_directions)
    throw Error(Errc::unsupported,
                fmt::format("{} holds f at exact directions (a table), not readings of this "
                            "instrument: there is nothing to calibrate against", data.source),
                "measured");
  const auto& grid = data.wavelengths;
  const auto sample = make_bsdf(sample_spec, grid);
  const auto reference = make_bsdf(profile.reference_bsdf, grid);
  const auto geo = distinct_geometries(data);
  const auto est = options.estimator_options();

  auto problem = base_problem(data);
  const auto ids = add_cal_parameters(problem, names, profile);
  const bool tilt = std::find(ids.begin(), ids.end(), CalParam::sample_tilt) != ids.end();
  if (tilt)
    for (const auto& g : geo.unique)
      if (!g.in_measurement_plane())
        throw Error(Errc::unsupported,
                    "sample_tilt_deg is modelled in the plane of measurement only; the data "
                    "have out-of-plane points",
                    "fit");

  const auto fixed = profile.calibration.mode == CalibrationMode::fixed;
  std::vector<FitResult> naive;
  if (options.naive) naive.push_back(naive_calibration(problem, data, *sample, profile, ids, options));

  problem.evaluate = [&](const std::vector<double>& x, std::vector<double>& beta,
                         std::vector<double>& se) {
    const auto v = cal_values(profile, ids, x);
    auto measured_with = corrected_profile(profile, v);
    measured_with.reference_beta = profile.reference_beta;  // the gain is applied below
    auto tilted = measured_with;
    tilted.arms.incidence_offset_deg += v.tilt;
    tilted.arms.receive_offset_deg -= v.tilt;
    const Twin twin(tilted, sample, reference, grid);
    const auto pred = twin.predict_many(geo.unique, est, options.threads);
    if (!tilt) return scatter(geo, pred, v.gain, nullptr, beta, se);
    // A tilted sample is the untilted one seen by arms offset by (+τ, −τ), while the
    // reference white (not tilted) is read where the arms really stand: the twin's ratio
    // used the tilted reading, so multiply by Φref(tilted arms) / Φref(actual arms).
    std::vector<double> rho(geo.unique.size(), 1.0);
    for (std::size_t k = 0; k < geo.unique.size(); ++k) {
      const auto& g = fixed ? profile.calibration.geometry : geo.unique[k];
      const double a = reference_flux(tilted, *reference, g, options);
      const double b = reference_flux(measured_with, *reference, g, options);
      rho[k] = b > 0 ? a / b : 1.0;
    }
    scatter(geo, pred, v.gain, &rho, beta, se);
  };
  if (!naive.empty() && naive.front().converged) start_from(problem, naive.front());
  fit::Optimum at;
  auto r = fit::solve(problem, options, &at);
  r.misfit = fit::misfit_regions(data, at);
  if (r.chi2_per_dof > options.misfit_limit) r.warnings.insert(r.warnings.begin(), fit::misfit_warning(r));
  const auto v = describe_calibration(r, data, *sample, profile, ids);
  if (tilt)
    r.warnings.push_back(fmt::format("the sample tilt ({:.3g}°) belongs to this mounting of the "
                                     "sample, not to the instrument: it is not in the profile",
                                     v.tilt));
  r.naive = std::move(naive);
  r.seconds = seconds_since(start);
  return r;
}

// ---- after the fit ---------------------------------------------------------------------------

std::vector<CorrectedPoint> correct(const MeasuredData& data, std::string_view fitted_spec,
                                    const InstrumentProfile& profile, const FitOptions& options) {
  options.validate();
  check_grid(data);
  const auto& grid = data.wavelengths;
  const Twin twin(profile, make_bsdf(fitted_spec, grid), grid);
  const auto geo = distinct_geometries(data);
  // Data at exact directions are compared with the model there: nothing to correct.
  const auto pred = data.exact_directions
                        ? std::vector<Prediction>{}
                        : twin.predict_many(geo.unique, options.estimator_options(), options.threads);
  std::vector<CorrectedPoint> out;
  for (std::size_t i = 0; i < data.points.size(); ++i) {
    const auto& m = data.points[i];
    CorrectedPoint c;
    c.geometry = m.geometry;
    c.measured = m.beta;
    c.measured_u = m.u;
    c.true_beta = twin.true_beta(m.geometry);
    if (data.exact_directions) {
      c.virtual_beta = c.true_beta;
      c.virtual_se.assign(c.true_beta.size(), 0.0);
      c.corrected = m.beta;
      c.corrected_u = m.u;
      out.push_back(std::move(c));
      continue;
    }
    const auto& p = pred[geo.of_point[i]];
    c.virtual_beta = p.beta;
    c.virtual_se = p.std_error;
    for (std::size_t k = 0; k < m.beta.size(); ++k) {
      const double ratio = p.beta[k] != 0 ? c.true_beta[k] / p.beta[k] : 1.0;
      c.corrected.push_back(m.beta[k] * ratio);
      c.corrected_u.push_back(std::abs(m.u[k] * ratio));
    }
    out.push_back(std::move(c));
  }
  return out;
}

// ---- JSON --------------------------------------------------------------------------------------

nlohmann::json FitResult::to_json() const {
  nlohmann::json params = nlohmann::json::array();
  for (const auto& p : parameters)
    params.push_back({{"name", p.name},
                      {"value", p.value},
                      {"u", number_or_null(p.u)},
                      {"start", p.start},
                      {"bounds", {p.lo, p.hi}},
                      {"at_bound", p.at_bound},
                      {"identifiable", p.identifiable}});
  nlohmann::json deg = nlohmann::json::array();
  for (const auto& d : degenerate) {
    nlohmann::json comb = nlohmann::json::object();
    for (const auto& [name, c] : d.combination) comb[name] = c;
    deg.push_back({{"combination", comb}, {"eigenvalue", d.eigenvalue}});
  }
  nlohmann::json corr = nlohmann::json::array();
  for (const auto& row : correlation) {
    nlohmann::json r = nlohmann::json::array();
    for (double v : row) r.push_back(number_or_null(v));
    corr.push_back(r);
  }
  nlohmann::json j{{"kind", kind},
                   {"parameters", params},
                   {"correlation", corr},
                   {"chi2", chi2},
                   {"chi2_per_dof", chi2_per_dof},
                   {"dof", dof},
                   {"points", points},
                   {"residuals", residuals},
                   {"iterations", iterations},
                   {"evaluations", evaluations},
                   {"seconds", seconds},
                   {"converged", converged},
                   {"status", status},
                   {"spec", spec},
                   {"warnings", warnings},
                   {"degenerate", deg}};
  nlohmann::json mis = nlohmann::json::array();
  for (const auto& m : misfit)
    mis.push_back({{"theta_i", m.theta_i},
                   {"region", m.region},
                   {"points", m.points},
                   {"chi2_share", m.chi2_share},
                   {"chi2_per_residual", m.chi2_per_residual},
                   {"rms_relative", m.rms_relative}});
  j["misfit"] = mis;
  j["nominal_directions"] = nominal_directions;
  j["naive"] = naive.empty() ? nlohmann::json(nullptr) : naive.front().to_json();
  if (profile) j["profile"] = *profile;
  return j;
}

}  // namespace gonio::twin
