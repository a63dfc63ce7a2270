// Twin: the virtual measurement of one geometry — adaptive sample counts, the ratio to
// the reference white, its standard error, and the fixed calibration mode.
#include "gonio/twin/twin.hpp"

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <thread>

#include <fmt/format.h>

#include "gonio/twin/detail/core/estimator.hpp"
#include "gonio/twin/detail/core/sobol.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::twin {
namespace {

using detail::FluxEstimator;
using detail::mix64;

std::uint64_t geometry_seed(std::uint64_t seed, const Geometry& g) {
  std::uint64_t h = mix64(seed);
  for (double v : {g.theta_i, g.phi_i, g.theta_r, g.phi_r}) {
    std::uint64_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    h = mix64(h ^ bits);
  }
  return h;
}

double correction_factor(GeometricCorrection c, const Geometry& g) {
  switch (c) {
    case GeometricCorrection::cos_receive: return std::abs(std::cos(g.theta_r * kDegToRad));
    case GeometricCorrection::cos_incidence: return std::cos(g.theta_i * kDegToRad);
    case GeometricCorrection::none: return 1.0;
  }
  return 1.0;
}

// Mean over replicates and the jackknife standard error of a ratio of means (or of a mean
// when `den` is null). Jackknife: Efron & Tibshirani, "An Introduction to the Bootstrap",
// ch. 11; it is the honest error bar for β = mean(Φs) / mean(Φr) at small R.
struct RatioStats {
  double value = 0, se = 0;
};

RatioStats ratio_stats(const std::vector<double>& num, const std::vector<double>* den) {
  const auto R = static_cast<double>(num.size());
  double sn = 0, sd = 0;
  for (std::size_t k = 0; k < num.size(); ++k) {
    sn += num[k];
    sd += den ? (*den)[k] : 1.0;
  }
  RatioStats out;
  if (!(sd > 0)) return out;
  out.value = sn / sd;
  if (num.size() < 2) return out;
  std::vector<double> loo(num.size());
  double mean = 0;
  for (std::size_t k = 0; k < num.size(); ++k) {
    const double d = sd - (den ? (*den)[k] : 1.0);
    loo[k] = d > 0 ? (sn - num[k]) / d : out.value;
    mean += loo[k];
  }
  mean /= R;
  double ss = 0;
  for (double v : loo) ss += (v - mean) * (v - mean);
  out.se = std::sqrt((R - 1) / R * ss);
  return out;
}

// Runs job(i) for i < n on `threads` workers (0: hardware concurrency), each taking the
// next index; the first exception stops the others and is rethrown.
template <class Job>
void for_each_geometry(std::size_t n, unsigned threads, const Job& job) {
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  threads = static_cast<unsigned>(std::min<std::size_t>(threads, n));
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  const auto worker = [&] {
    for (;;) {
      const std::size_t i = next.fetch_add(1);
      if (i >= n) return;
      try {
        job(i);
      } catch (...) {
        std::lock_guard lock(error_mutex);
        if (!error) error = std::current_exception();
        next = n;
      }
    }
  };
  if (threads <= 1) {
    worker();
  } else {
    std::vector<std::thread> pool;
    for (unsigned t = 0; t < threads; ++t) pool.emplace_back(worker);
    for (auto& t : pool) t.join();
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace

void EstimatorOptions::validate() const {
  if (!(rel_se >= 1e-6 && rel_se <= 1))
    throw Error::out_of_range("rel_se", rel_se, 1e-6, 1);
  if (!(abs_se >= 0 && abs_se <= 1)) throw Error::out_of_range("abs_se", abs_se, 0, 1);
  if (replicates < 4 || replicates > 256)
    throw Error::out_of_range("replicates", replicates, 4, 256);
  if (first_points < 4 || first_points > 4096 || (first_points & (first_points - 1)) != 0)
    throw Error::invalid("first_points",
                         fmt::format("{} is not a power of two from 4 to 4096", first_points));
  if (max_samples < 1024 || max_samples > (1ull << 34))
    throw Error::out_of_range("max_samples", static_cast<double>(max_samples), 1024,
                              static_cast<double>(1ull << 34));
}

Twin::Twin(InstrumentProfile profile, BsdfPtr sample, WavelengthGrid grid)
    : Twin(std::move(profile), std::move(sample), nullptr, std::move(grid)) {}

Twin::Twin(InstrumentProfile profile, BsdfPtr sample, BsdfPtr reference, WavelengthGrid grid)
    : profile_(std::move(profile)), sample_(std::move(sample)), reference_(std::move(reference)),
      grid_(std::move(grid)), fixed_(std::make_shared<FixedReference>()) {
  profile_.validate();
  if (!sample_) throw Error::invalid("bsdf", "no sample BSDF");
  if (sample_->wavelengths() != grid_)
    throw Error::invalid("bsdf", "the sample BSDF was built for another wavelength grid");
  if (!reference_) reference_ = make_bsdf(profile_.reference_bsdf, grid_);
  if (reference_->wavelengths() != grid_)
    throw Error::invalid("profile.reference_bsdf", "built for another wavelength grid");
}

Twin Twin::with_profile(InstrumentProfile profile) const {
  return Twin(std::move(profile), sample_, reference_, grid_);
}

std::vector<double> Twin::true_beta(const Geometry& g) const {
  const auto a = g.incident_direction();
  const auto b = g.receiving_direction();
  std::vector<double> f(grid_.size());
  sample_->eval({a[0], a[1], a[2]}, {b[0], b[1], b[2]}, f);
  for (double& v : f) v *= kPi;
  return f;
}

// Φ_reference at the calibration geometry, estimated once per Twin and options, per
// channel: value and relative variance.
struct Twin::FixedReference {
  std::mutex mutex;
  bool ready = false;
  EstimatorKind kind{};
  std::uint64_t seed = 0;
  std::vector<double> flux, rel_var;
  std::uint64_t samples = 0;
};

Prediction Twin::predict(const Geometry& g, const EstimatorOptions& options) const {
  return std::move(predict_with(g, options, {}).front());
}

std::vector<Prediction> Twin::predict_with(const Geometry& g, const EstimatorOptions& options,
                                           const std::vector<const Bsdf*>& variants) const {
  options.validate();
  g.validate();
  const auto start = std::chrono::steady_clock::now();
  const bool fixed = profile_.calibration.mode == CalibrationMode::fixed;
  const std::size_t C = grid_.size();
  const int R = options.replicates;

  const auto setup = detail::make_setup(profile_, g);
  FluxEstimator est(setup, *sample_, fixed ? nullptr : reference_.get(), options.kind,
                    geometry_seed(options.seed, g), R, variants);

  std::vector<Prediction> all(1 + variants.size());
  for (auto& p : all) {
    p.geometry = g;
    p.wavelengths = grid_;
    p.beta.assign(C, 0.0);
    p.std_error.assign(C, 0.0);
  }
  Prediction& out = all.front();

  // Fixed mode: the reference flux at the calibration geometry, carried by the correction.
  std::vector<double> ref_flux(C, 0.0), ref_rel_var(C, 0.0);
  if (fixed) {
    auto& fr = *fixed_;
    std::lock_guard lock(fr.mutex);
    if (!fr.ready || fr.kind != options.kind || fr.seed != options.seed) {
      // The sample alone is estimated below; the calibration reading is a separate run
      // with a tighter target so that it does not dominate the error budget.
      auto ref_opts = options;
      ref_opts.rel_se = options.rel_se / 4;
      const auto cal_setup = detail::make_setup(profile_, profile_.calibration.geometry);
      FluxEstimator cal(cal_setup, *reference_, nullptr, options.kind,
                        geometry_seed(options.seed ^ 0xca11b7a7e, profile_.calibration.geometry), R);
      std::uint64_t n = 256;
      for (;;) {
        cal.run_until(n);
        bool done = true;
        fr.flux.assign(C, 0.0);
        fr.rel_var.assign(C, 0.0);
        for (std::size_t c = 0; c < C; ++c) {
          std::vector<double> v(static_cast<std::size_t>(R));
          for (int r = 0; r < R; ++r) v[static_cast<std::size_t>(r)] = cal.sample_flux(r, c);
          const auto st = ratio_stats(v, nullptr);
          fr.flux[c] = st.value;
          fr.rel_var[c] = st.value > 0 ? (st.se / st.value) * (st.se / st.value) : 0;
          if (st.se > ref_opts.rel_se * st.value) done = false;
        }
        if (done || static_cast<std::uint64_t>(R) * n * 2 > options.max_samples) break;
        n *= 2;
      }
      fr.samples = static_cast<std::uint64_t>(R) * cal.points_per_replicate();
      fr.kind = options.kind;
      fr.seed = options.seed;
      fr.ready = true;
    }
    const double scale = correction_factor(profile_.calibration.correction, g) /
                         correction_factor(profile_.calibration.correction,
                                           profile_.calibration.geometry);
    for (std::size_t c = 0; c < C; ++c) {
      ref_flux[c] = fr.flux[c] * scale;
      ref_rel_var[c] = fr.rel_var[c];
    }
  }

  const std::uint64_t paths_per_point = static_cast<std::uint64_t>(R) * (fixed ? 1 : 2);
  std::uint64_t n = options.first_points;
  std::vector<double> num(static_cast<std::size_t>(R)), den(static_cast<std::size_t>(R));
  // β and its s.e. of channel c for the sample (v = 0) or variant v − 1.
  const auto estimate = [&](std::size_t v, std::size_t c, double& beta_out, double& se_out) {
    for (int r = 0; r < R; ++r) {
      num[static_cast<std::size_t>(r)] = v == 0 ? est.sample_flux(r, c) : est.variant_flux(v - 1, r, c);
      den[static_cast<std::size_t>(r)] = fixed ? 1.0 : est.reference_flux(r, c);
    }
    const auto st = ratio_stats(num, &den);
    double beta = 0, se = 0;
    if (fixed) {
      if (ref_flux[c] > 0) {
        beta = st.value / ref_flux[c];
        const double rel = st.value > 0 ? st.se / st.value : 0;
        se = std::abs(beta) * std::sqrt(rel * rel + ref_rel_var[c]);
      }
    } else {
      beta = st.value, se = st.se;
    }
    beta_out = beta * profile_.reference_beta;
    se_out = se * profile_.reference_beta;
  };
  for (;;) {
    est.run_until(n);
    bool converged = true;
    for (std::size_t c = 0; c < C; ++c) {
      estimate(0, c, out.beta[c], out.std_error[c]);
      if (out.std_error[c] > std::max(options.rel_se * std::abs(out.beta[c]), options.abs_se))
        converged = false;
    }
    out.diagnostics.converged = converged;
    if (converged || paths_per_point * n * 2 > options.max_samples) break;
    n *= 2;
  }
  for (std::size_t v = 1; v < all.size(); ++v)
    for (std::size_t c = 0; c < C; ++c) estimate(v, c, all[v].beta[c], all[v].std_error[c]);
  const auto diag = est.diagnostics();
  out.diagnostics.sampling = diag.sampling;
  out.diagnostics.seen_fraction = diag.seen_fraction;
  out.diagnostics.mean_theta_i = diag.mean_theta_i;
  out.diagnostics.mean_theta_r = diag.mean_theta_r;
  out.samples = paths_per_point * est.points_per_replicate();
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (std::size_t v = 1; v < all.size(); ++v) {
    all[v].diagnostics = out.diagnostics;
    all[v].samples = out.samples;
    all[v].seconds = out.seconds;
  }
  return all;
}

std::vector<std::vector<Prediction>> Twin::predict_variants(
    const std::vector<Geometry>& geometries, const std::vector<BsdfPtr>& variants,
    const EstimatorOptions& options, unsigned threads) const {
  options.validate();
  std::vector<const Bsdf*> raw;
  for (std::size_t v = 0; v < variants.size(); ++v) {
    if (!variants[v] || variants[v]->wavelengths() != grid_)
      throw Error::invalid(fmt::format("variants[{}]", v),
                           "must be a BSDF built for the twin's wavelength grid");
    raw.push_back(variants[v].get());
  }
  for (std::size_t i = 0; i < geometries.size(); ++i)
    geometries[i].validate(fmt::format("geometry[{}]", i));
  std::vector<std::vector<Prediction>> out(geometries.size());
  for_each_geometry(geometries.size(), threads,
                    [&](std::size_t i) { out[i] = predict_with(geometries[i], options, raw); });
  return out;
}

std::vector<Prediction> Twin::predict_many(const std::vector<Geometry>& geometries,
                                           const EstimatorOptions& options,
                                           unsigned threads) const {
  options.validate();
  for (std::size_t i = 0; i < geometries.size(); ++i)
    geometries[i].validate(fmt::format("geometry[{}]", i));
  std::vector<Prediction> out(geometries.size());
  for_each_geometry(geometries.size(), threads,
                    [&](std::size_t i) { out[i] = predict(geometries[i], options); });
  return out;
}

}  // namespace gonio::twin
