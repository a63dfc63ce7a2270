// The inverse twin: material fit and instrument self-calibration through the virtual
// instrument (method and figures: twin/fitting.md).
//
// Both are pure functions of the measured points, a model, an instrument profile and
// options; they do no I/O (the loaders below read files, the callers write results), so
// the CLI (`gonio-twin fit`, `gonio-twin calibrate`) and a daemon call the same code.
//
//   fit_material     a BSDF spec with free parameters marked '?'
//                    ("conductor:alpha=?,eta=0.2,k=3.9", "alpha=?0.1[0.001,1]") is fitted
//                    so that the twin's virtual measurement matches the data.
//   calibrate        a known sample; free instrument parameters (arm offsets, sample tilt,
//                    aperture scales, gain) are fitted instead.
//
// The objective is weighted least squares, r = (β_virtual − β_measured) / √(u² + s²) with u
// the measurement's and s the twin's standard error; the virtual measurement uses a fixed
// sample budget and seed (common random numbers), so it is a smooth deterministic function
// of the parameters. Levenberg–Marquardt (Eigen's unsupported module, after MINPACK's
// lmder) runs in a transformed space that keeps every parameter inside its bounds.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "gonio/proto/geometry.hpp"
#include "gonio/proto/spectrum.hpp"
#include "gonio/twin/instrument.hpp"
#include "gonio/twin/twin.hpp"

namespace gonio::twin {

// ---- measured data ---------------------------------------------------------------------

struct MeasuredPoint {
  Geometry geometry;          // nominal (as the instrument reports it)
  std::vector<double> beta;   // measured radiance factor per channel
  std::vector<double> u;      // its standard uncertainty (k = 1) per channel, > 0
};

struct MeasuredData {
  WavelengthGrid wavelengths;       // shared by every point
  std::vector<MeasuredPoint> points;
  std::string source;               // file name or description, for messages
  // The values are f at exactly these directions (a tabulated BSDF: its instrument's
  // optics are already in it or unknown), not readings through this instrument: a fit
  // compares them with the model at the nominal directions.
  bool exact_directions = false;

  std::size_t residuals() const noexcept { return points.size() * wavelengths.size(); }
  // Throws Error(invalid_argument) naming the first bad point or value.
  void validate() const;
};

// goniod's `scan.export --format csv`: one row per point and wavelength. Columns are read by
// name: theta_i, phi_i, theta_r, phi_r, wavelength_nm, measured, measured_u are required,
// all others ignored. Rows of one point share `index` (or, without that column, follow one
// another with the same geometry). Throws Error(parse_error) naming the line.
MeasuredData parse_measured_csv(std::string_view text, const std::string& source = "csv");
// goniod's `scan.export --format json` ({"scan": ..., "points": [PointRecord...]}) or a
// bare array of PointRecords.
MeasuredData measured_from_json(const nlohmann::json& j, const std::string& source = "json");
// What a table's values are given as uncertainty (tables carry none):
// u = √((rel·β)² + abs²), so that zero and tiny values do not dominate χ².
struct TableUncertainty {
  double rel = 0.01;   // relative, (0, 1]
  double abs = 0.002;  // absolute, in β (radiance factor), [0, 1]
  void validate() const;
};

// By extension: .csv, .json, or a tabulated BSDF (.bsdf IS-SA, .ssdd). A table gives the
// in-plane reflection geometries at each of its incidence angles ≤ 85° (receiving angles
// −85…85° every 2.5°) that it covers (BsdfTable::covers: inside its measured extent, no
// unmeasured node in the interpolation), with β = π f through its own interpolation, the
// uncertainty `table`, and exact_directions set. Errors: not_found, parse_error.
MeasuredData load_measured(const std::string& path, const TableUncertainty& table = {});

// ---- the model with free parameters ------------------------------------------------------

// One free parameter of a spec template, in the order of the '?' marks.
struct FreeParameter {
  std::string name;   // "conductor.alpha", "lambert.albedo@550" (per channel or per pair)
  double start = 0;
  double lo = 0, hi = 0;  // bounds (closed)
  bool log_scale = false; // fitted in log space (positive range over more than a decade)
};

// A BSDF spec in which '?' marks free parameters:
//   ?                 free, started at the model's default, bounded by its range
//   ?0.1              started at 0.1
//   ?0.1[0.001,1]     ... and bounded to [0.001, 1]
//   ?*                (spectral parameters) free per wavelength channel of the fit
// A '?' may also stand for the value of one wavelength:value pair of a spectrum
// ("eta=400:?,700:?"). Sums of lobes work. Built once per grid; spec() substitutes values.
class ModelTemplate {
 public:
  // Throws Error(invalid_argument) naming the lobe and key for a bad mark, a scalar
  // parameter marked per channel, bounds outside the model's range, or no '?' at all.
  ModelTemplate(std::string_view spec, const WavelengthGrid& grid);

  const std::vector<FreeParameter>& parameters() const noexcept { return params_; }
  std::size_t size() const noexcept { return params_.size(); }
  // The spec with every free parameter set (values in the order of parameters()).
  std::string spec(const std::vector<double>& values) const;
  const std::string& text() const noexcept { return text_; }
  // For each parameter, the wavelength channel it acts on alone (per-channel marks), or −1.
  const std::vector<int>& channel() const noexcept { return channel_; }

 private:
  std::string text_;
  std::vector<FreeParameter> params_;
  std::vector<int> channel_;
  // Literal text and marks interleaved: literal_[k] precedes mark k.
  std::vector<std::string> literal_;
  struct Mark {
    std::size_t first = 0;   // index of its first parameter
    std::size_t count = 1;   // channels for a per-channel mark, else 1
  };
  std::vector<Mark> marks_;
  WavelengthGrid grid_;
};

// ---- options and results -----------------------------------------------------------------

struct FitOptions {
  // The twin's budget per evaluation: a fixed sample count (rel_se is not used) and a fixed
  // seed, the same at every evaluation (common random numbers).
  std::uint64_t samples = 1u << 13;  // paths per geometry, sample + reference (max_samples)
  int replicates = 16;
  std::uint64_t seed = 1;
  EstimatorKind estimator = EstimatorKind::rqmc;
  unsigned threads = 0;              // 0: all cores
  int max_iterations = 60;           // Levenberg–Marquardt iterations (Jacobians)
  double tolerance = 1e-6;           // relative change of parameters / χ² to stop
  bool naive = true;                 // also fit at the nominal directions (no instrument)
  double correlation_limit = 0.95;   // |ρ| above this: not separable
  // Global start: candidates (the given start and Sobol points over the bounds) for the
  // parameters acting on every channel, each refined briefly at the nominal directions
  // before the fit proper; ≤ 1: the given start only.
  int starts = 12;
  // Start values in the order of the '?' marks, replacing the template's (a warm start from
  // an earlier fit); empty: the template's. Values outside a bound are moved inside it.
  std::vector<double> start;
  // χ²/dof above this is a misfit: a warning names the worst regions.
  double misfit_limit = 2;
  void validate() const;
  EstimatorOptions estimator_options() const;
};

struct FittedParameter {
  std::string name;
  double value = 0;
  double u = 0;              // standard uncertainty (k = 1): scaled by √(χ²/dof) when > 1, and for a
                             // misfit at least the scatter of its geometries' pull (twin/fitting.md)
  double start = 0, lo = 0, hi = 0;
  bool at_bound = false;     // the optimum lies on a bound: u is not meaningful
  bool identifiable = true;  // false: strongly correlated or on a flat direction
};

// A combination of parameters the data cannot tell apart: the unit vector (in parameters
// scaled by their uncertainties) along which χ² hardly changes.
struct Degeneracy {
  std::vector<std::pair<std::string, double>> combination;  // name, component
  double eigenvalue = 0;  // of the correlation matrix; ≈ 0: flat
};

// A region of the data: one incidence angle and one part of the receiving range.
struct MisfitRegion {
  double theta_i = 0;
  // "specular" (within 10° of the mirror direction), "grazing" (θr > 70°, not specular),
  // "backscatter" (the source's side of the normal), "diffuse" (the rest), "out-of-plane".
  std::string region;
  std::size_t points = 0;
  double chi2_share = 0;   // of the total χ², 0–1
  double chi2_per_residual = 0;
  double rms_relative = 0; // RMS of (fitted − measured) / measured over its residuals
};

struct FitResult {
  std::string kind;                          // "fit" or "calibrate"
  std::vector<FittedParameter> parameters;   // in the order of the '?' marks / the list
  std::vector<std::vector<double>> correlation;
  double chi2 = 0;
  double chi2_per_dof = 0;
  long dof = 0;
  std::size_t points = 0;                    // measured geometries
  std::size_t residuals = 0;                 // geometries × channels
  int iterations = 0;                        // Jacobian evaluations
  int evaluations = 0;                       // virtual measurements of the whole data set
  double seconds = 0;
  bool converged = false;
  std::string status;                        // the optimiser's stopping reason
  std::string spec;                          // fitted BSDF spec (fit) or the sample's (calibrate)
  std::vector<std::string> warnings;
  std::vector<Degeneracy> degenerate;
  // Where the model misses the data most, worst first (at most 5): always given, the
  // warning above misfit_limit quotes them.
  std::vector<MisfitRegion> misfit;
  // Fitted at the nominal directions, not through the instrument (exact_directions data).
  bool nominal_directions = false;
  std::optional<InstrumentProfile> profile;  // calibrate: the corrected profile
  // The same fit with the model at the nominal directions (no instrument).
  std::vector<FitResult> naive;              // zero or one element

  nlohmann::json to_json() const;
};

// Fits the free parameters of `model` (a spec with '?' marks) to `data` through the twin of
// `profile`. Throws Error for bad input (invalid_argument naming the field).
FitResult fit_material(const MeasuredData& data, std::string_view model,
                       const InstrumentProfile& profile, const FitOptions& options = {});

// The fittable instrument parameters (calibrate).
//   incidence_offset_deg, receive_offset_deg  true arm angle = reported + offset
//   sample_tilt_deg          rotation of the sample (not the reference) about the axis
//                            perpendicular to the plane of measurement; positive tilts the
//                            normal toward the receiver side (+x)
//   source_aperture_scale, receiver_aperture_scale   multiply both full angles
//   gain                     reported β = gain × the instrument's β (reference white's factor)
const std::vector<std::string>& calibration_parameters();

// Fits the listed instrument parameters with `sample` known. The result's `profile` is
// `profile` corrected (offsets, aperture angles, reference_beta × gain); the sample tilt
// belongs to the mounting, not the instrument, and is reported only.
FitResult calibrate(const MeasuredData& data, std::string_view sample,
                    const std::vector<std::string>& parameters, const InstrumentProfile& profile,
                    const FitOptions& options = {});

// ---- after the fit -----------------------------------------------------------------------

// Per point and channel: the fitted model's virtual measurement (with s.e.), its true β at
// the nominal directions, and the instrument-corrected measurement measured × true/virtual.
struct CorrectedPoint {
  Geometry geometry;
  std::vector<double> measured, measured_u, virtual_beta, virtual_se, true_beta, corrected,
      corrected_u;
};
std::vector<CorrectedPoint> correct(const MeasuredData& data, std::string_view fitted_spec,
                                    const InstrumentProfile& profile,
                                    const FitOptions& options = {});

}  // namespace gonio::twin
