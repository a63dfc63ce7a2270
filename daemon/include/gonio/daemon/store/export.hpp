// scan.export — a scan's points as CSV, JSON, Zemax/Radiant IS-SA `.bsdf` or SSDD text.
//
//   csv   one row per point and wavelength: geometry planned and read back, measured β and
//         its standard uncertainty, predicted β and its standard error, z, ΔE00, flags
//   json  {"scan": ..., "points": [PointRecord...]}
//   bsdf, ssdd  the measured BRDF f = β/π as an isotropic spherical table (twin/bsdf_io.hpp):
//         θi = the scan's incidence angles, θo = |θr|, φo = 180° for θr > 0 (forward) and
//         0° for θr < 0, repeats averaged, negative values (noise around zero after the
//         dark subtraction) clamped to 0. The scan must cover the full grid θi × θo × sides
//         of its own in-plane reflection points; otherwise use csv or json.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "gonio/proto/point.hpp"
#include "gonio/proto/scan.hpp"

namespace gonio::daemon {

struct ExportResult {
  std::string format;     // "csv", "json", "bsdf", "ssdd"
  std::string filename;   // "scan-12.csv"
  std::string media_type;
  std::string content;
};

// Throws Error(invalid_argument) for an unknown format (field "format"), Error(unsupported)
// when the points do not form a table for bsdf/ssdd.
ExportResult export_scan(const Scan& scan, const std::vector<PointRecord>& points,
                         std::string_view format);

// One chunk of a csv or json export: the points from `offset` on. Chunks from offset 0 to
// the one marked `last` concatenate into the whole file (csv: the header comes with the
// first chunk; json: the first opens {"scan": ..., "points": [ and the last closes it).
// This keeps a large scan's export out of one in-memory document.
ExportResult export_chunk(const Scan& scan, const std::vector<PointRecord>& points,
                          std::string_view format, std::size_t offset, bool last);

}  // namespace gonio::daemon
