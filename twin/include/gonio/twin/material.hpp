// Materials out of gonio: a fitted or catalogued BSDF spec written for the renderers its
// users work in (twin/material.md).
//
//   Mitsuba 3 scene XML   the spec's lobes as Mitsuba's own plugins, parameter for parameter,
//                         spectra as Mitsuba spectra; a lobe Mitsuba cannot express is refused
//   glTF 2.0 (.gltf)      a sphere with the metallic-roughness material (+ KHR_materials_ior,
//                         _specular, _clearcoat): an approximation, fitted to the spec by
//                         CIEDE2000 and reported with its error
//   MERL (.binary)        the 90 × 90 × 180 half-angle table sampled from the model
//
// A spec a format cannot express raises Error(unsupported) whose field names the lobe
// ("bsdf.oren-nayar") and whose message names the format and the reason.
#pragma once

#include <array>
#include <iosfwd>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "gonio/proto/enum_text.hpp"
#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/render.hpp"

namespace gonio::twin::material {

enum class Format { mitsuba, gltf, merl };
inline constexpr EnumNames<Format, 3> kFormatNames{{
    {Format::mitsuba, "mitsuba"},
    {Format::gltf, "gltf"},
    {Format::merl, "merl"},
}};
constexpr const auto& enum_names(Format) { return kFormatNames; }

// ---- Mitsuba 3 ------------------------------------------------------------------------------
// A scene (version 3.0.0) holding the material as <bsdf id="material">, a unit sphere using
// it, a constant environment and a sensor, so that `mitsuba scene.xml` renders it. `spec` is
// built (and so validated) on `grid` first; the XML carries its canonical parameters.
std::string mitsuba_scene(std::string_view spec, const WavelengthGrid& grid);
// The spec the material of a scene written by mitsuba_scene stands for (the plugins and
// parameters that writer uses; anything else is Error(unsupported) / Error(parse_error)).
std::string spec_from_mitsuba(std::string_view xml);

// ---- glTF 2.0 ---------------------------------------------------------------------------------
// The metallic-roughness material with the three extensions, in glTF's linear RGB.
struct GltfMaterial {
  std::array<double, 3> base_color{1, 1, 1};
  double metallic = 1, roughness = 1, ior = 1.5, specular = 1;
  std::array<double, 3> specular_color{1, 1, 1};
  double clearcoat = 0, clearcoat_roughness = 0.03;
};

// The twin's own spec of a glTF material (the `gltf` model): RGB colours become the spectra
// rgb_spectrum gives. Not the inverse of gltf_from_spec: the ramps are not the sRGB primaries,
// so a colour's spectrum has the colour spectrum_rgb gives, not the RGB it was made from.
std::string gltf_spec(const GltfMaterial& m);
// A `gltf` spec read back as glTF parameters: its spectra's colours as linear sRGB (D65, CIE
// 1931 2°, the renderer's colorimetry), each component clipped to [0, 1].
GltfMaterial gltf_from_spec(std::string_view spec, const WavelengthGrid& grid);

// Linear RGB (glTF's colours) as a spectrum in the spec syntax: a partition of unity of
// three ramps (blue below 470 nm, green 530–560 nm, red above 610 nm, linear between), so
// that every colour in [0, 1]³ is a reflectance in [0, 1] and grey stays flat.
std::string rgb_spectrum(const std::array<double, 3>& rgb);
// Linear sRGB of a reflectance spectrum on `grid` under D65 (CIE 1931 2°, white-aligned as
// the renderer does: a flat 1 is (1, 1, 1)).
std::array<double, 3> spectrum_rgb(std::span<const double> values, const WavelengthGrid& grid);

// A .gltf document: one UV sphere (radius 1, `rings` × 2·`rings` quads, positions and
// normals in an embedded base64 buffer) with the material.
std::string gltf_document(const GltfMaterial& m, std::string_view name, int rings = 48);

struct GltfFitOptions {
  int max_iterations = 40;
  RenderOptions check;   // the studio render the result is checked on
  bool render_check = true;
  std::string plot;      // when not empty: the two studio renders and their ΔE00 map, a PNG
};
struct DeltaESummary {
  double mean = 0, p95 = 0, max = 0;
  std::size_t samples = 0;  // geometries or pixels
};
struct GltfFit {
  GltfMaterial material;       // what the file holds: gltf_from_spec(spec)
  std::string spec;            // the fitted material as the twin's `gltf` spec
  DeltaESummary geometries;    // the objective: ΔE00 over the fitting geometries
  std::optional<DeltaESummary> studio;  // ΔE00 of the studio renders (pixels on the sphere)
  double studio_noise_mean = 0;         // what the renders' own noise gives
  int iterations = 0;
  std::string start;           // which start won
};
// Fits the glTF parameters minimising CIEDE2000 between `target` and the glTF model over
// the fitting geometries (fit_geometries), then checks the result on the studio render.
GltfFit fit_gltf(const Bsdf& target, const GltfFitOptions& options = {});

// The fitting geometries: (wi, wo) pairs about the specular direction of every θi, as a
// point light of unit irradiance shows them (twin/material.md).
struct GeometryPair {
  Vec3 wi, wo;
};
std::vector<GeometryPair> fit_geometries();
// Displayed colour (CIELAB of the clipped linear sRGB, as the sphere render shows it) of
// π f(wi, wo) cos θi for every pair; one Lab per pair.
std::vector<Lab> geometry_colors(const Bsdf& b, const std::vector<GeometryPair>& pairs);

// ---- MERL -------------------------------------------------------------------------------------
// The model sampled at the MERL nodes (θh = 90°(k/90)², θd = 90°·k/90, φd = 180°·k/180, the
// reader's mapping) at the three wavelengths the reader assigns to R, G and B
// (kRgbWavelengthsNm), stored with the database's channel scales. Nodes whose directions
// fall below the horizon hold the value just above it.
void write_merl(std::ostream& out, const Bsdf& model);
void write_merl(const std::string& path, const Bsdf& model);

// The largest relative difference between `table` (as the twin reads it back) and `model`
// over the in-plane hemisphere: θi 0–min(80°, max_theta_r) every 5°, θr ±max_theta_r every
// 1°, on the three MERL
// wavelengths, relative to max(f_model, 0.01/π) (below a radiance factor of 0.01 the
// difference counts as absolute).
struct RoundTrip {
  double max_rel = 0, mean_rel = 0;
  double theta_i = 0, theta_r = 0;  // where the largest is
};
RoundTrip merl_round_trip(const Bsdf& model, const Bsdf& table, double max_theta_r = 85);

// ---- the command's whole job ------------------------------------------------------------------
struct ExportReport {
  Format format = Format::mitsuba;
  std::string spec;                  // what was exported (canonical)
  std::optional<GltfFit> gltf;
  std::optional<RoundTrip> merl;
  std::vector<std::string> notes;    // what the export approximates, per lobe
};
// Writes `spec` to `path` in `format`. Throws Error(unsupported) for what the format cannot
// express, Error(io_error) when the file cannot be written.
// `grid`: the wavelengths the spec is built and compared on (MERL uses its own three).
ExportReport export_material(std::string_view spec, Format format, const std::string& path,
                             const WavelengthGrid& grid, const GltfFitOptions& options = {});

}  // namespace gonio::twin::material
