// Readers and writers of tabulated BSDF files; what each format holds and how its angles map
// onto the sample frame is in twin/bsdf_formats.md.
//
//   .bsdf    Zemax / Radiant Imaging IS-SA "BSDF Data Interchange" text (one BRDF or BTDF,
//            specular parametrization, Monochrome or XYZ)
//   .ssdd    Surface Scattering Distribution Data (libbsdf's format: BRDF, BTDF, specular
//            reflectance and transmittance, any parametrization, ASCII or binary data)
//   .binary  MERL BRDF database (Matusik et al. 2003): isotropic RGB BRDF in half-difference
//            angles, read-only
//
// Every reader rejects malformed input with gonio::Error(parse_error) whose message starts
// with "<source>:<line>:" (or the byte offset for binary data) and never trusts a size from
// a header: storage grows only with data actually read, under BsdfTable::kMaxValues.
// Features a reader recognises but cannot represent raise Error(unsupported); files that
// cannot be opened raise Error(not_found) or Error(io_error).
#pragma once

#include <array>
#include <iosfwd>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "gonio/twin/tabulated.hpp"

namespace gonio::twin {

// MERL and SSDD `rgb` data become a three-point spectrum at the dominant wavelengths of the
// sRGB primaries (IEC 61966-2-1 chromaticities, D65 white, CIE 1931 2° locus), nm, in the
// order blue, green, red. See bsdf_formats.md.
inline constexpr std::array<double, 3> kRgbWavelengthsNm{464.3, 549.1, 611.5};

// ---- Zemax / Radiant IS-SA ---------------------------------------------------------------
// Returns a specular-parametrization table in `brdf` or `btdf` (ScatterType). Monochrome
// data are grey; XYZ data keep their Y (luminance factor) as a grey table.
TabulatedParts read_issa(std::istream& in, std::string_view source = "<stream>");
TabulatedParts read_issa(const std::string& path);

struct IssaWriteOptions {
  // The file's grid, degrees. Empty: the table's own axes when it is a specular table;
  // otherwise incidence = the table's θi (spherical) or 0:80:10, azimuth 0:180:5
  // (PlaneSymmetrical) or 0:355:5, radial a list refined near the specular direction.
  std::vector<double> incidence, azimuth, radial;
  // Monochrome content: the weighted mean of the table's channels (weights normalised to
  // sum 1; empty = plain mean).
  std::vector<double> weights;
  // XYZ content instead: X, Y, Z = Σ weight·f over the table's channels, weights as given
  // (e.g. CIE colour-matching functions times an illuminant, normalised so that Y of a
  // non-selective table equals its value).
  std::optional<std::array<std::vector<double>, 3>> xyz_weights;
  std::string comment;  // written as '#' lines at the top
  // The table marks directions it did not measure with nodes that are 0 in every channel
  // (in_plane_table_with_gaps; neither IS-SA nor SSDD defines another "no data" value): a
  // node of the file interpolated from such a node, or beyond the table's measured extent,
  // is written as 0 too, so that a gap stays a gap instead of a blend with it; and a
  // spherical table's in-plane nodes join the default radial list, so that every measured
  // value is written as it is.
  bool keep_gaps = false;
};
// Writes one table (BRDF, or BTDF when `transmission`). Values are f in sr⁻¹; TIS per
// channel and angle of incidence is the directional-hemispherical integral of the file's own
// values as a reader interpolates them (table_albedo of what is written). Returns one
// warning per angle of incidence whose reflectance (Y or Monochrome) exceeds 1, naming it;
// the warnings are also written as '#' comments at the top of the file.
std::vector<std::string> write_issa(std::ostream& out, const BsdfTable& table, bool transmission,
                                    const IssaWriteOptions& options = {});
std::vector<std::string> write_issa(const std::string& path, const BsdfTable& table,
                                    bool transmission, const IssaWriteOptions& options = {});

// ---- SSDD ----------------------------------------------------------------------------------
TabulatedParts read_ssdd(std::istream& in, std::string_view source = "<stream>");
TabulatedParts read_ssdd(const std::string& path);

enum class SsddData { ascii, binary };
// What goes into the optional entries of SSDD 0.3 (libbsdf doc/SsddFileFormatSpecification.md,
// version 0.3): none of them is needed by a reader, so each is written only when set.
enum class SsddSource { unset, measured, generated, edited };
struct SsddWriteOptions {
  SsddData data = SsddData::ascii;  // binary = IEEE 754 float32, little-endian
  std::string comment;              // '#' lines before VERSION
  std::string software = "gonio";   // SOFTWARE entry (empty: omitted)
  std::string date;                 // DATE entry, YYYY-MM-DD (empty: omitted)
  SsddSource source = SsddSource::unset;  // SOURCE_TYPE of every block
  std::string device;               // DEVICE of every block (empty: omitted)
  // NAME of every block from TabulatedParts::name (when it is not empty), so that write →
  // read keeps the parts exactly. Off: the name goes into a '#' comment line instead — what
  // `gonio-twin convert` does, since readers do not use NAME (libbsdf logs it as not
  // implemented).
  bool name_entry = true;
};
// Writes every part present. Grey tables are `monochrome`, others `spectrum`. Returns one
// warning per incidence angle of a BRDF / BTDF table whose directional reflectance
// (transmittance) exceeds 1 in some channel, naming the angle; they are also written as '#'
// comments before VERSION.
std::vector<std::string> write_ssdd(std::ostream& out, const TabulatedParts& parts,
                                    const SsddWriteOptions& options = {});
std::vector<std::string> write_ssdd(const std::string& path, const TabulatedParts& parts,
                                    const SsddWriteOptions& options = {});

// ---- MERL ------------------------------------------------------------------------------------
// Header of three little-endian int32 (θh, θd, φd resolution: 90, 90, 180 in the database),
// then R, G, B blocks of doubles scaled by 1/1500, 1.15/1500, 1.66/1500. Other resolutions
// are read with the same mapping (θh nodes at 90°·(k/n)², θd at 90°·k/n, φd at 180°·k/n).
// Negative entries, the database's mark of unmeasured samples, become 0.
TabulatedParts read_merl(std::istream& in, std::string_view source = "<stream>");
TabulatedParts read_merl(const std::string& path);

// ---- by extension ---------------------------------------------------------------------------
// .bsdf → read_issa, .ssdd → read_ssdd, .binary → read_merl (case-insensitive).
TabulatedParts read_bsdf_file(const std::string& path);
// .ssdd → write_ssdd (all parts); .bsdf → write_issa of the single BRDF or BTDF (a file with
// both, or with specular parts, needs .ssdd: Error(unsupported)). `issa` applies to .bsdf.
// Returns the writer's energy warnings.
std::vector<std::string> write_bsdf_file(const std::string& path, const TabulatedParts& parts,
                                         const IssaWriteOptions& issa = {},
                                         const SsddWriteOptions& ssdd = {});

}  // namespace gonio::twin
