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
#include <cmath>
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

nlohmann::json tolerance_json(const Tolerance& t) {
  nlohmann::json j{{"distribution", to_text(t.distribution)}};
  if (t.distribution != Distribution::normal) {
    j["half_width"] = t.half_width;
  } else if (!t.spectral.empty()) {
    auto nodes = nlohmann::json::array();
    for (const auto& [nm, u] : t.spectral) nodes.push_back({nm, u});
    j["u"] = std::move(nodes);
  } else {
    j["u"] = t.u;
  }
  return j;
}

// {"distribution": "rectangular", "half_width": 0.5} | {"distribution": "normal", "u": 0.002}
// | {"distribution": "normal", "u": [[400, 0.005], [700, 0.003]]}. The distribution is
// required: a bare number could be a half-width or a standard uncertainty.
Tolerance read_tolerance(const nlohmann::json& j, const std::string& field, double hi) {
  ObjectReader r(j, field);
  if (!r.has("distribution"))
    throw Error::invalid(r.path("distribution"),
                         "is required (rectangular, triangular or normal): a tolerance without "
                         "its distribution has no standard uncertainty");
  Tolerance t;
  const auto d = r.required<std::string>("distribution");
  if (const auto named = from_text<Distribution>(d))
    t.distribution = *named;
  else
    throw Error::invalid(r.path("distribution"),
                         fmt::format("'{}' (allowed: rectangular, triangular, normal)", d));
  if (t.distribution != Distribution::normal) {
    if (r.has("u"))
      throw Error::invalid(r.path("u"), fmt::format("a {} tolerance is stated as half_width", d));
    t.half_width = r.required_in<double>("half_width", 0.0, hi);
  } else {
    if (r.has("half_width"))
      throw Error::invalid(r.path("half_width"),
                           "a normal tolerance is stated as its standard uncertainty u");
    const auto* u = r.raw("u");
    if (!u) throw Error::invalid(r.path("u"), "is required for a normal tolerance");
    if (u->is_array()) {
      double last = 0;
      for (std::size_t i = 0; i < u->size(); ++i) {
        const auto f = fmt::format("{}[{}]", r.path("u"), i);
        const auto& node = (*u)[i];
        if (!node.is_array() || node.size() != 2) throw Error::invalid(f, "expected [nm, u]");
        const auto nm = json_util::get_as<double>(node[0], f + "[0]");
        const auto v = json_util::get_as<double>(node[1], f + "[1]");
        if (!(nm >= 200 && nm <= 2500)) throw Error::out_of_range(f + "[0]", nm, 200, 2500, " nm");
        if (i > 0 && !(nm > last)) throw Error::invalid(f + "[0]", "wavelengths must increase");
        if (!(v >= 0 && v <= hi)) throw Error::out_of_range(f + "[1]", v, 0, hi);
        last = nm;
        t.spectral.emplace_back(nm, v);
      }
      if (t.spectral.empty()) throw Error::invalid(r.path("u"), "has no [nm, u] node");
    } else {
      t.u = json_util::get_as<double>(*u, r.path("u"));
      if (!(t.u >= 0 && t.u <= hi)) throw Error::out_of_range(r.path("u"), t.u, 0, hi);
    }
  }
  r.finish();
  return t;
}

// Tolerance keys: name, the largest value that makes sense, whether it may be spectral.
struct ToleranceKey {
  const char* name;
  double hi;
};
constexpr ToleranceKey kToleranceKeys[] = {
    {"incidence_arm_deg", 10},     {"receive_arm_deg", 10},     {"arm_repeatability_deg", 10},
    {"source_aperture_rel", 0.5},  {"receiver_aperture_rel", 0.5}, {"reference_white_rel", 0.2},
    {"lamp_stability_rel", 0.2},
};

}  // namespace

double Tolerance::standard_uncertainty(double wavelength_nm) const {
  switch (distribution) {
    case Distribution::rectangular: return half_width / std::sqrt(3.0);
    case Distribution::triangular: return half_width / std::sqrt(6.0);
    case Distribution::normal: break;
  }
  if (spectral.empty()) return u;
  if (wavelength_nm <= spectral.front().first) return spectral.front().second;
  if (wavelength_nm >= spectral.back().first) return spectral.back().second;
  for (std::size_t i = 1; i < spectral.size(); ++i) {
    const auto& [x1, y1] = spectral[i];
    if (wavelength_nm > x1) continue;
    const auto& [x0, y0] = spectral[i - 1];
    return y0 + (y1 - y0) * (wavelength_nm - x0) / (x1 - x0);
  }
  return spectral.back().second;
}

double Tolerance::kurtosis() const {
  switch (distribution) {
    case Distribution::rectangular: return 9.0 / 5.0;
    case Distribution::triangular: return 12.0 / 5.0;
    case Distribution::normal: return 3.0;
  }
  return 3.0;
}

Tolerance InstrumentProfile::incidence_arm_tolerance() const {
  return tolerances.incidence_arm_deg.value_or(
      Tolerance{Distribution::rectangular, arms.accuracy_deg, 0, {}});
}

Tolerance InstrumentProfile::receive_arm_tolerance() const {
  return tolerances.receive_arm_deg.value_or(
      Tolerance{Distribution::rectangular, arms.accuracy_deg, 0, {}});
}

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
      {"tolerances",
       {{"arm_repeatability_deg", tolerance_json(p.tolerances.arm_repeatability_deg)},
        {"source_aperture_rel", tolerance_json(p.tolerances.source_aperture_rel)},
        {"receiver_aperture_rel", tolerance_json(p.tolerances.receiver_aperture_rel)},
        {"reference_white_rel", tolerance_json(p.tolerances.reference_white_rel)},
        {"lamp_stability_rel", tolerance_json(p.tolerances.lamp_stability_rel)}}},
  };
  // The arms' own only when stated: otherwise they follow arms.accuracy_deg.
  if (p.tolerances.incidence_arm_deg)
    j["tolerances"]["incidence_arm_deg"] = tolerance_json(*p.tolerances.incidence_arm_deg);
  if (p.tolerances.receive_arm_deg)
    j["tolerances"]["receive_arm_deg"] = tolerance_json(*p.tolerances.receive_arm_deg);
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
  if (const auto* s = r.raw("tolerances")) {
    ObjectReader rt(*s, "profile.tolerances");
    auto& t = p.tolerances;
    const auto read = [&](const ToleranceKey& k) -> std::optional<Tolerance> {
      const auto* node = rt.raw(k.name);
      if (!node) return std::nullopt;
      return read_tolerance(*node, rt.path(k.name), k.hi);
    };
    t.incidence_arm_deg = read(kToleranceKeys[0]);
    t.receive_arm_deg = read(kToleranceKeys[1]);
    Tolerance* fields[] = {&t.arm_repeatability_deg, &t.source_aperture_rel, &t.receiver_aperture_rel,
                           &t.reference_white_rel, &t.lamp_stability_rel};
    for (std::size_t i = 0; i < std::size(fields); ++i) {
      const auto& key = kToleranceKeys[i + 2];
      auto v = read(key);
      if (!v) continue;
      if (!v->spectral.empty() && std::string_view(key.name) != "reference_white_rel")
        throw Error::invalid(rt.path(key.name) + ".u",
                             "only reference_white_rel may vary with wavelength");
      *fields[i] = std::move(*v);
    }
    for (const auto* arm : {&t.incidence_arm_deg, &t.receive_arm_deg})
      if (*arm && !(*arm)->spectral.empty())
        throw Error::invalid(rt.path(arm == &t.incidence_arm_deg ? "incidence_arm_deg" : "receive_arm_deg") + ".u",
                             "only reference_white_rel may vary with wavelength");
    rt.finish();
  }
  r.finish();
  p.validate();
}

}  // namespace gonio::twin
