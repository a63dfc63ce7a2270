// Flux estimators of the virtual instrument (private to the twin).
//
// The detector flux for a geometry is (L0 = beam radiance, dropped: it cancels in β)
//
//   Φ = ∫_Ωr dωo ∫_Ωs dωi  f(ωi, ωo) |cos θi| |cos θo| A(ωi, ωo)
//
// where Ωs, Ωr are the source and receiver angular apertures and A is the area of the
// sample-plane region that is lit along ωi, seen along ωo and on the sample (or reference
// plate): A = area(beam footprint(ωi) ∩ field footprint(ωo) ∩ plate). Derivation: a patch
// dA lit by the beam receives dE = L0 |cos θi| dωi; it sends L = ∫ f dE toward ωo, and the
// receiver (equal weight for every ray in its field and aperture, ASTM E179) collects
// L |cos θo| dA dωo. The spatial integral is done exactly (polygon clipping); the 4-D
// angular one by Monte Carlo:
//
//   rqmc      ωo uniform in Ωr (tangent plane); ωi uniform in Ωs — and, for a lobe
//             narrower than Ωs, from the lobe's own shape truncated to Ωs about ωo's mirror
//             direction (lobe_sampler.hpp), or, for other BSDFs that vary on the aperture's
//             scale, by BSDF importance sampling given ωo; combined with the balance or
//             power heuristic (Veach 1997, §9.2); delta lobes exactly. Points are
//             Owen-scrambled Sobol, one scramble per replicate.
//   baseline  the founding paper's scheme (eqs. 2–5): a uniform point on the receiver's
//             pupil and a uniform direction over the detector's (slit's) aperture, weighted
//             by (n·v)^4 = cos⁴γ; the ray is followed to the sample plane; ωi uniform in Ωs;
//             plain pseudo-random Monte Carlo.
//
// Both estimate the same Φ (dA_pupil cosγ = dA_sample |cos θo| for a fixed ray direction).
// The reference white runs with the same random numbers (common random numbers), so β
// = Φ_sample / Φ_reference has far less variance than either flux.
#pragma once

#include <cstdint>
#include <vector>

#include "gonio/twin/detail/core/optics.hpp"
#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/twin.hpp"

namespace gonio::twin::detail {

struct MeasurementSetup {
  ArmFrame source, receiver;  // actual arm directions (nominal + offsets)
  Aperture source_aperture, receiver_aperture;
  Footprint beam, field;
  Extent sample_mm, reference_mm;
  bool transmission = false;  // receiver below the sample plane
  double receive_phi = 0;     // azimuth of the receiver's plane of measurement, radians
};

MeasurementSetup make_setup(const InstrumentProfile& profile, const Geometry& nominal);

class FluxEstimator {
 public:
  // `reference` may be null (fixed calibration: the sample alone). `variants` are further
  // samples (the same grid) whose flux is estimated on the sample's own paths: the same
  // directions, footprints and weights, which come from the sample's densities. The
  // weights of the strategies still sum to one for every variant, so each estimate is
  // unbiased, and the differences between them carry no Monte Carlo noise of their own
  // beyond what the integrands' differences make (common random numbers, exactly).
  FluxEstimator(const MeasurementSetup& setup, const Bsdf& sample, const Bsdf* reference,
                EstimatorKind kind, std::uint64_t seed, int replicates,
                std::vector<const Bsdf*> variants = {});

  // Extends every replicate to `n` points (n a power of two for rqmc).
  void run_until(std::uint64_t n);

  std::uint64_t points_per_replicate() const noexcept { return n_; }
  int replicates() const noexcept { return replicates_; }
  std::size_t channels() const noexcept { return channels_; }
  // Mean flux of replicate r, channel c.
  double sample_flux(int r, std::size_t c) const noexcept {
    return sums_[static_cast<std::size_t>(r) * channels_ + c] / static_cast<double>(n_);
  }
  double reference_flux(int r, std::size_t c) const noexcept {
    return ref_sums_[static_cast<std::size_t>(r) * channels_ + c] / static_cast<double>(n_);
  }
  // Mean flux of variant v (0-based, in the order given), replicate r, channel c.
  double variant_flux(std::size_t v, int r, std::size_t c) const noexcept {
    return variant_sums_[(v * static_cast<std::size_t>(replicates_) + static_cast<std::size_t>(r)) *
                             channels_ + c] / static_cast<double>(n_);
  }
  std::size_t variants() const noexcept { return variants_.size(); }
  Diagnostics diagnostics() const;

 private:
  struct Accumulator;
  struct RqmcPoint;
  static bool narrow_at_aperture_scale(const MeasurementSetup& s, const Bsdf& bsdf, bool reference);
  void run_rqmc(int r, std::uint64_t begin, std::uint64_t end);
  void run_baseline(int r, std::uint64_t begin, std::uint64_t end);

  const MeasurementSetup& setup_;
  const Bsdf& sample_;
  const Bsdf* reference_;
  EstimatorKind kind_;
  std::uint64_t seed_;
  int replicates_;
  std::size_t channels_;
  std::uint64_t n_ = 0;
  std::vector<double> sums_, ref_sums_;
  std::vector<const Bsdf*> variants_;
  std::vector<double> variant_sums_;  // [variant][replicate][channel]
  // Diagnostics: flux-weighted sums (channel-mean weights).
  bool sample_narrow_ = false, reference_narrow_ = false;  // use BSDF sampling (MIS)
  // Strategy 3's scales per tangent axis (0: not used), see lobe_scale().
  Vec2 lobe_scale_{0, 0};
  static Vec2 lobe_scale(const MeasurementSetup& s, const Bsdf& bsdf);
  // Whether strategy 3 draws the sample's ωi alone, see lobe_alone().
  bool lobe_alone_ = false;
  static bool lobe_alone(const MeasurementSetup& s, const Bsdf& bsdf, Vec2 scale);
  double w_sum_ = 0, w_seen_ = 0, w_lit_ = 0, w_theta_i_ = 0, w_theta_r_ = 0;
};

}  // namespace gonio::twin::detail
