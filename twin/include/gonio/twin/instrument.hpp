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

#include <string>
#include <string_view>

#include <nlohmann/json_fwd.hpp>

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
