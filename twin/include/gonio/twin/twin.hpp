// Twin — the virtual measurement: predicts the radiance factor the instrument reports.
//
// For a geometry, the twin estimates the detector flux for the sample and for the
// reference white (per-geometry or fixed calibration, see InstrumentProfile) and reports
// β = Φ_sample / Φ_reference × β_reference per wavelength channel, with its standard
// error from R independent randomisations.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "gonio/proto/enum_text.hpp"
#include "gonio/proto/geometry.hpp"
#include "gonio/proto/spectrum.hpp"
#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/estimator_options.hpp"
#include "gonio/twin/instrument.hpp"

namespace gonio::twin {

// How the rqmc estimator drew the sample's source directions (estimator.hpp): uniformly over
// the aperture; that and BSDF sampling (power heuristic); from the lobe's own shape alone;
// the lobe's shape and the uniform draw (balance heuristic). The baseline has its own.
enum class SourceSampling { aperture, aperture_bsdf, lobe, lobe_aperture, baseline };
inline constexpr EnumNames<SourceSampling, 5> kSourceSamplingNames{{
    {SourceSampling::aperture, "aperture"},
    {SourceSampling::aperture_bsdf, "aperture+bsdf"},
    {SourceSampling::lobe, "lobe"},
    {SourceSampling::lobe_aperture, "lobe+aperture"},
    {SourceSampling::baseline, "baseline"},
}};
constexpr const auto& enum_names(SourceSampling) { return kSourceSamplingNames; }  // proto/enum_text.hpp

struct Diagnostics {
  SourceSampling sampling = SourceSampling::aperture;
  double seen_fraction = 1;   // flux-weighted fraction of the lit footprint that is seen
  double mean_theta_i = 0;    // flux-weighted mean incidence angle, degrees
  double mean_theta_r = 0;    // flux-weighted mean receiving angle, degrees (signed)
  bool converged = false;     // rel_se reached within the budget
};

struct Prediction {
  Geometry geometry;                 // nominal
  WavelengthGrid wavelengths;
  std::vector<double> beta;          // radiance factor per channel
  std::vector<double> std_error;     // standard error per channel (k = 1)
  std::uint64_t samples = 0;         // paths traced, sample + reference
  double seconds = 0;
  Diagnostics diagnostics;

  Spectrum spectrum() const { return Spectrum(wavelengths, beta, std_error); }
};

class Twin {
 public:
  // Throws Error if the profile is invalid or the BSDF's grid differs from `grid`. The
  // reference white is built from profile.reference_bsdf unless given explicitly.
  Twin(InstrumentProfile profile, BsdfPtr sample, WavelengthGrid grid);
  Twin(InstrumentProfile profile, BsdfPtr sample, BsdfPtr reference, WavelengthGrid grid);

  const InstrumentProfile& profile() const noexcept { return profile_; }
  const WavelengthGrid& wavelengths() const noexcept { return grid_; }
  const Bsdf& sample() const noexcept { return *sample_; }

  // The same sample and reference with another profile (a calibration's, a tolerance's).
  Twin with_profile(InstrumentProfile profile) const;

  // Thread-safe; deterministic for options.seed and the geometry.
  Prediction predict(const Geometry& g, const EstimatorOptions& options = {}) const;
  // Spreads geometries over `threads` workers (0: hardware concurrency). Results are in
  // input order and identical to calling predict() one by one.
  std::vector<Prediction> predict_many(const std::vector<Geometry>& geometries,
                                       const EstimatorOptions& options = {},
                                       unsigned threads = 0) const;

  // Predictions of this twin's sample and of `variants` (BSDFs on the same grid, e.g. the
  // sample with one parameter stepped each: a Jacobian) traced on the same paths: the
  // sample's directions, footprints, weights and reference readings. Each is unbiased (the
  // weights of the strategies come from the sample's densities and still sum to one), the
  // differences between them carry the common random numbers exactly, and the footprint
  // clipping — most of a path's cost — is done once for all. Per geometry, the sample's
  // prediction first (identical to predict()), then one per variant; the stopping rule is
  // the sample's. Throws Error for a variant built on another grid.
  std::vector<std::vector<Prediction>> predict_variants(const std::vector<Geometry>& geometries,
                                                        const std::vector<BsdfPtr>& variants,
                                                        const EstimatorOptions& options = {},
                                                        unsigned threads = 0) const;
  // The true radiance factor π·f(ωi, ωr) at the nominal directions (no instrument).
  std::vector<double> true_beta(const Geometry& g) const;

 private:
  std::vector<Prediction> predict_with(const Geometry& g, const EstimatorOptions& options,
                                       const std::vector<const Bsdf*>& variants) const;
  InstrumentProfile profile_;
  BsdfPtr sample_;
  BsdfPtr reference_;
  WavelengthGrid grid_;
  struct FixedReference;
  std::shared_ptr<FixedReference> fixed_;  // calibration reading of the fixed mode, cached
};

}  // namespace gonio::twin
