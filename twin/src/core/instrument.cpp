// InstrumentProfile: the built-in presets, strict JSON loading and range checks.
//
// gcms4 numbers are from the founding paper (Murakami GCMS-4 data): source angular
// aperture 2.1° in the plane of measurement × 4.2° across it; receiver (detector) angular
// aperture 1.6° × 1.4°; receiving slit 2.8 × 2.4 mm; viewed area 8 × 16 mm at θr = 0; arm
// accuracy ±0.5°; luminous source rectangle 5 × 2 mm. The paper does not say which side of
// the 5 × 2 mm rectangle lies in the plane of measurement; we orient it like the angular
// aperture (narrow side in-plane: 2 mm in-plane, 5 mm across), so the lit spot fits inside
// the viewed area at θr = 0 up to θi ≈ 76° and overflows it beyond — the paper's "part of
// the illuminated spot is not visible" at large incidence. Sample and reference plate sizes
// are not in the paper: 100 × 100 mm, large enough for the viewed area up to θr ≈ 85°.
// Nor is the arms' clearance: 10° (instrument.hpp says why), so that no profile lets the
// two arms meet (θi = 45°, θr = −44° puts them 1° apart).
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"
#include "gonio/twin/instrument.hpp"

namespace gonio::twin {
namespace {

using json_util::ObjectReader;

const char* shape_name(ApertureShape s) {
  return s == ApertureShape::rectangle ? "rectangle" : "ellipse";
}

ApertureShape parse_shape(const std::string& s, const std::string& field) {
  if (s == "rectangle") return ApertureShape::rectangle;
  if (s == "ellipse") return ApertureShape::ellipse;
  throw Error::invalid(field, fmt::format("'{}' is not a shape (allowed: rectangle, ellipse)", s));
}

const char* mode_name(CalibrationMode m) {
  return m == CalibrationMode::per_geometry ? "per-geometry" : "fixed";
}

const char* correction_name(GeometricCorrection c) {
  switch (c) {
    case GeometricCorrection::cos_receive: return "cos-receive";
    case GeometricCorrection::cos_incidence: return "cos-incidence";
    case GeometricCorrection::none: return "none";
  }
  return "none";
}

nlohmann::json extent_json(const Extent& e) { return nlohmann::json::array({e.in_plane, e.perpendicular}); }

Extent read_extent(ObjectReader& r, const std::string& key, Extent fallback) {
  const auto* j = r.raw(key);
  if (!j) return fallback;
  const auto field = r.path(key);
  if (!j->is_array() || j->size() != 2)
    throw Error::invalid(field, "expected [in_plane, perpendicular]");
  return {json_util::get_as<double>((*j)[0], field + "[0]"),
          json_util::get_as<double>((*j)[1], field + "[1]")};
}

void check_extent(const Extent& e, const std::string& field, double lo, double hi,
                  std::string_view unit) {
  if (!(e.in_plane >= lo && e.in_plane <= hi))
    throw Error::out_of_range(field + "[0]", e.in_plane, lo, hi, unit);
  if (!(e.perpendicular >= lo && e.perpendicular <= hi))
    throw Error::out_of_range(field + "[1]", e.perpendicular, lo, hi, unit);
}

void check(double v, const std::string& field, double lo, double hi, std::string_view unit = {}) {
  if (!(v >= lo && v <= hi)) throw Error::out_of_range(field, v, lo, hi, unit);
}

}  // namespace

InstrumentProfile InstrumentProfile::preset(std::string_view name) {
  if (name == "gcms4") return InstrumentProfile{};
  throw Error(Errc::not_found, fmt::format("profile '{}' is not a preset (presets: gcms4)", name),
              "profile");
}

InstrumentProfile InstrumentProfile::load(std::string_view name_or_path) {
  if (name_or_path.find('/') == std::string_view::npos &&
      name_or_path.find('.') == std::string_view::npos)
    return preset(name_or_path);
  const std::string path(name_or_path);
  std::ifstream in(path);
  if (!in)
    throw Error(Errc::not_found, fmt::format("profile file '{}' cannot be opened", path),
                "profile");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw Error(Errc::parse_error, fmt::format("profile file '{}': {}", path, e.what()),
                "profile");
  }
  return j.get<InstrumentProfile>();
}

void InstrumentProfile::validate() const {
  check_extent(source.aperture_deg, "profile.source.aperture_deg", 0.01, 30, "°");
  check_extent(source.beam_mm, "profile.source.beam_mm", 0.01, 500, " mm");
  check_extent(receiver.aperture_deg, "profile.receiver.aperture_deg", 0.01, 30, "°");
  check_extent(receiver.field_mm, "profile.receiver.field_mm", 0.01, 500, " mm");
  check_extent(receiver.slit_mm, "profile.receiver.slit_mm", 0.01, 100, " mm");
  check_extent(sample_mm, "profile.sample_mm", 0.1, 2000, " mm");
  check_extent(reference_mm, "profile.reference_mm", 0.1, 2000, " mm");
  check(arms.incidence_offset_deg, "profile.arms.incidence_offset_deg", -10, 10, "°");
  check(arms.receive_offset_deg, "profile.arms.receive_offset_deg", -10, 10, "°");
  check(arms.accuracy_deg, "profile.arms.accuracy_deg", 0, 10, "°");
  check(arms.min_separation_deg, "profile.arms.min_separation_deg", 0, 90, "°");
  check(reference_beta, "profile.reference_beta", 0.01, 2);
  if (reference_bsdf.empty()) throw Error::invalid("profile.reference_bsdf", "is empty");
  calibration.geometry.validate("profile.calibration.geometry");
  if (calibration.geometry.is_transmission())
    throw Error::invalid("profile.calibration.geometry",
                         "the reference white is read in reflection");
}

void to_json(nlohmann::json& j, const InstrumentProfile& p) {
  j = nlohmann::json{
      {"name", p.name},
      {"source",
       {{"aperture_deg", extent_json(p.source.aperture_deg)},
        {"beam_mm", extent_json(p.source.beam_mm)},
        {"aperture_shape", shape_name(p.source.aperture_shape)},
        {"beam_shape", shape_name(p.source.beam_shape)}}},
      {"receiver",
       {{"aperture_deg", extent_json(p.receiver.aperture_deg)},
        {"field_mm", extent_json(p.receiver.field_mm)},
        {"slit_mm", extent_json(p.receiver.slit_mm)},
        {"aperture_shape", shape_name(p.receiver.aperture_shape)},
        {"field_shape", shape_name(p.receiver.field_shape)}}},
      {"sample_mm", extent_json(p.sample_mm)},
      {"reference_mm", extent_json(p.reference_mm)},
      {"arms",
       {{"incidence_offset_deg", p.arms.incidence_offset_deg},
        {"receive_offset_deg", p.arms.receive_offset_deg},
        {"accuracy_deg", p.arms.accuracy_deg},
        {"min_separation_deg", p.arms.min_separation_deg}}},
      {"reference_bsdf", p.reference_bsdf},
      {"reference_beta", p.reference_beta},
      {"calibration",
       {{"mode", mode_name(p.calibration.mode)},
        {"geometry", p.calibration.geometry},
        {"correction", correction_name(p.calibration.correction)}}},
  };
}

void from_json(const nlohmann::json& j, InstrumentProfile& p) {
  p = InstrumentProfile{};
  ObjectReader r(j, "profile");
  p.name = r.optional<std::string>("name", p.name);
  if (const auto* s = r.raw("source")) {
    ObjectReader rs(*s, "profile.source");
    p.source.aperture_deg = read_extent(rs, "aperture_deg", p.source.aperture_deg);
    p.source.beam_mm = read_extent(rs, "beam_mm", p.source.beam_mm);
    p.source.aperture_shape = parse_shape(
        rs.optional<std::string>("aperture_shape", "rectangle"), rs.path("aperture_shape"));
    p.source.beam_shape =
        parse_shape(rs.optional<std::string>("beam_shape", "rectangle"), rs.path("beam_shape"));
    rs.finish();
  }
  if (const auto* s = r.raw("receiver")) {
    ObjectReader rr(*s, "profile.receiver");
    p.receiver.aperture_deg = read_extent(rr, "aperture_deg", p.receiver.aperture_deg);
    p.receiver.field_mm = read_extent(rr, "field_mm", p.receiver.field_mm);
    p.receiver.slit_mm = read_extent(rr, "slit_mm", p.receiver.slit_mm);
    p.receiver.aperture_shape = parse_shape(
        rr.optional<std::string>("aperture_shape", "rectangle"), rr.path("aperture_shape"));
    p.receiver.field_shape =
        parse_shape(rr.optional<std::string>("field_shape", "rectangle"), rr.path("field_shape"));
    rr.finish();
  }
  p.sample_mm = read_extent(r, "sample_mm", p.sample_mm);
  p.reference_mm = read_extent(r, "reference_mm", p.reference_mm);
  if (const auto* s = r.raw("arms")) {
    ObjectReader ra(*s, "profile.arms");
    p.arms.incidence_offset_deg = ra.optional<double>("incidence_offset_deg", 0.0);
    p.arms.receive_offset_deg = ra.optional<double>("receive_offset_deg", 0.0);
    p.arms.accuracy_deg = ra.optional<double>("accuracy_deg", p.arms.accuracy_deg);
    p.arms.min_separation_deg = ra.optional<double>("min_separation_deg", InstrumentProfile{}.arms.min_separation_deg);
    ra.finish();
  }
  p.reference_bsdf = r.optional<std::string>("reference_bsdf", p.reference_bsdf);
  p.reference_beta = r.optional<double>("reference_beta", p.reference_beta);
  if (const auto* s = r.raw("calibration")) {
    ObjectReader rc(*s, "profile.calibration");
    const auto mode = rc.optional<std::string>("mode", "per-geometry");
    if (mode == "per-geometry")
      p.calibration.mode = CalibrationMode::per_geometry;
    else if (mode == "fixed")
      p.calibration.mode = CalibrationMode::fixed;
    else
      throw Error::invalid(rc.path("mode"),
                           fmt::format("'{}' (allowed: per-geometry, fixed)", mode));
    if (rc.has("geometry"))
      p.calibration.geometry = rc.required<Geometry>("geometry");
    else
      (void)rc.raw("geometry");
    const auto corr = rc.optional<std::string>("correction", "cos-receive");
    if (corr == "cos-receive")
      p.calibration.correction = GeometricCorrection::cos_receive;
    else if (corr == "cos-incidence")
      p.calibration.correction = GeometricCorrection::cos_incidence;
    else if (corr == "none")
      p.calibration.correction = GeometricCorrection::none;
    else
      throw Error::invalid(rc.path("correction"),
                           fmt::format("'{}' (allowed: cos-receive, cos-incidence, none)", corr));
    rc.finish();
  }
  r.finish();
  p.validate();
}

}  // namespace gonio::twin
