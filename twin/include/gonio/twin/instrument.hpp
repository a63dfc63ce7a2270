// InstrumentProfile — every parameter of the instrument model (docs/architecture.md §3).
//
// The built-in `gcms4` preset carries the numbers of the founding paper. Angles are full
// angles in degrees, lengths in mm. Axes of a rectangle are (in-plane, perpendicular): the
// first runs in the plane of measurement, the second across it.
//
//   source    a collimated beam: a luminous cross-section (beam_mm, perpendicular to the
//             beam axis, through the sample centre) whose every point emits with uniform
//             radiance into the angular aperture (aperture_deg) around the axis.
//   receiver  an ideal lens whose slit sets the angular aperture (aperture_deg) and whose
//             entrance pupil, perpendicular to the receiver axis, sets the viewed area
//             (field_mm at θr = 0, growing as 1/cos θr on the sample). Every ray inside
//             both is weighted equally (ASTM E179).
//   sample / reference plate  rectangles on the sample plane (outside them nothing scatters).
//   arms      angle offsets of the incidence and receiving arms (misalignment), and the
//             minimum angular separation of source and receiver (collision guard).
//   calibration  per-geometry: the reference white is read at each geometry;
//             fixed: read once at `geometry` and carried to others by `correction`.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "gonio/proto/enum_text.hpp"
#include "gonio/proto/geometry.hpp"

namespace gonio::twin {

enum class ApertureShape { rectangle, ellipse };
enum class CalibrationMode { per_geometry, fixed };
// How a fixed-mode instrument scales the reference reading from its calibration geometry
// to another geometry: by cos θr (lit spot assumed fully seen), by cos θi (viewed area
// assumed fully lit), or not at all.
enum class GeometricCorrection { cos_receive, cos_incidence, none };

struct Extent {
  double in_plane = 0;       // along the plane of measurement
  double perpendicular = 0;  // across it
  friend bool operator==(const Extent&, const Extent&) = default;
};

// How a stated tolerance is distributed (GUM, JCGM 100:2008 §4.3.7–4.3.9): a data sheet's
// "±a" is rectangular unless it says otherwise; a calibration certificate's u is normal.
// Named as the profile and the budget spell it (proto/enum_text.hpp).
enum class Distribution { rectangular, triangular, normal };
inline constexpr EnumNames<Distribution, 3> kDistributionNames{{
    {Distribution::rectangular, "rectangular"},
    {Distribution::triangular, "triangular"},
    {Distribution::normal, "normal"},
}};
constexpr const auto& enum_names(Distribution) { return kDistributionNames; }

// One stated tolerance: ±half_width (rectangular, triangular) or a standard uncertainty u
// (normal, k = 1). `spectral` (normal only) gives u per wavelength instead, as nm:u nodes
// interpolated linearly and held constant beyond the first and last.
struct Tolerance {
  Distribution distribution = Distribution::rectangular;
  double half_width = 0;
  double u = 0;
  std::vector<std::pair<double, double>> spectral;
  // The standard uncertainty: a/√3 (rectangular), a/√6 (triangular), u (normal); at
  // `wavelength_nm` for a spectral one.
  double standard_uncertainty(double wavelength_nm = 0) const;
  // E[x⁴]/u⁴ of the distribution (9/5, 12/5, 3): the second-order term of the budget.
  double kurtosis() const;
  friend bool operator==(const Tolerance&, const Tolerance&) = default;
};

// The instrument's stated tolerances, the inputs of the twin's uncertainty budget
// (twin/include/gonio/twin/budget.hpp). Arm accuracies default to ±arms.accuracy_deg. The
// others are not in the GCMS-4 paper; the defaults are typical of the class of instrument and
// a site states its own: apertures ±3 % of their angle, a white standard certified to
// u = 0.5 % at 400 nm and 0.3 % from 500 nm on (Spectralon-class certificates), the lamp stable to 0.1 % between
// the white's reading and the sample's, and the arms repeatable to ±0.05° per move.
struct Tolerances {
  std::optional<Tolerance> incidence_arm_deg;  // unset: rectangular ±arms.accuracy_deg
  std::optional<Tolerance> receive_arm_deg;    // unset: rectangular ±arms.accuracy_deg
  Tolerance arm_repeatability_deg{Distribution::rectangular, 0.05, 0, {}};
  Tolerance source_aperture_rel{Distribution::rectangular, 0.03, 0, {}};
  Tolerance receiver_aperture_rel{Distribution::rectangular, 0.03, 0, {}};
  Tolerance reference_white_rel{Distribution::normal, 0, 0, {{400, 0.005}, {500, 0.003}}};
  Tolerance lamp_stability_rel{Distribution::normal, 0, 0.001, {}};
  friend bool operator==(const Tolerances&, const Tolerances&) = default;
};

struct InstrumentProfile {
  std::string name = "gcms4";
  struct Source {
    Extent aperture_deg{2.1, 4.2};
    Extent beam_mm{2.0, 5.0};
    ApertureShape aperture_shape = ApertureShape::rectangle;
    ApertureShape beam_shape = ApertureShape::rectangle;
    friend bool operator==(const Source&, const Source&) = default;
  } source;
  struct Receiver {
    Extent aperture_deg{1.6, 1.4};
    Extent field_mm{8.0, 16.0};
    Extent slit_mm{2.8, 2.4};  // documents the lens; the angular aperture is authoritative
    ApertureShape aperture_shape = ApertureShape::rectangle;
    ApertureShape field_shape = ApertureShape::rectangle;
    friend bool operator==(const Receiver&, const Receiver&) = default;
  } receiver;
  Extent sample_mm{100.0, 100.0};
  Extent reference_mm{100.0, 100.0};
  struct Arms {
    double incidence_offset_deg = 0;
    double receive_offset_deg = 0;
    double accuracy_deg = 0.5;         // data-sheet angular accuracy (±)
    // Collision guard between the two arms: the closest they may come, in degrees of
    // |θi + θr|. Both beams alone need half of each in-plane aperture plus both arms'
    // accuracy (gcms4: 1.05 + 0.8 + 2 × 0.5 = 2.85°); the arm housings, which the profile
    // does not model, need more. 10° is the default of every real motion driver too; an
    // installation sets its measured clearance ([instrument.limits] min_separation).
    double min_separation_deg = 10;
    friend bool operator==(const Arms&, const Arms&) = default;
  } arms;
  std::string reference_bsdf = "lambert:albedo=1";
  double reference_beta = 1.0;  // β the instrument assigns to its white standard
  struct Calibration {
    CalibrationMode mode = CalibrationMode::per_geometry;
    Geometry geometry = Geometry::in_plane(0, 45);
    GeometricCorrection correction = GeometricCorrection::cos_receive;
    friend bool operator==(const Calibration&, const Calibration&) = default;
  } calibration;
  Tolerances tolerances;

  // The arms' stated accuracy as a tolerance (the tolerances' own, else ±arms.accuracy_deg).
  Tolerance incidence_arm_tolerance() const;
  Tolerance receive_arm_tolerance() const;

  // Built-in presets by name ("gcms4"); throws Error(not_found) listing the names.
  static InstrumentProfile preset(std::string_view name);
  // A preset name, or a path to a JSON profile file (keys as in to_json; missing keys keep
  // the gcms4 values, unknown keys are rejected).
  static InstrumentProfile load(std::string_view name_or_path);
  // Range-checks every parameter; throws Error naming it.
  void validate() const;

  friend bool operator==(const InstrumentProfile&, const InstrumentProfile&) = default;
};

void to_json(nlohmann::json& j, const InstrumentProfile& p);
void from_json(const nlohmann::json& j, InstrumentProfile& p);

}  // namespace gonio::twin
