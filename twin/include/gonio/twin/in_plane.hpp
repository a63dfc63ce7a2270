// In-plane reflection readings (β per channel at geometries with φi = φr = 0) as an
// isotropic spherical BRDF table, f = β/π: what goniod's tabulated exports and
// gonio-twin fit --corrected write.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "gonio/proto/geometry.hpp"
#include "gonio/twin/tabulated.hpp"

namespace gonio::twin {

struct InPlaneReading {
  Geometry geometry;
  std::span<const double> beta;  // one value per channel; negative noise counts as 0
  std::int64_t index = -1;       // the point's index, named in errors when known (>= 0)
};

// How an error names the readings and what it suggests instead.
struct InPlaneErrorText {
  std::string what = "the points";  // "the points are not a full grid"
  std::string remedy;               // "export csv or json"
  std::string field;                // Error::field()
};

// θi and |θr| nodes of the readings, φo = 0 (θr < 0) and 180 (θr > 0), both at θr = 0 (the
// normal lies on both sides); repeats are averaged. Throws Error(unsupported) for a reading
// out of the plane or in transmission, and when the readings do not fill the grid.
BsdfTable in_plane_table(std::span<const InPlaneReading> readings,
                         std::vector<double> wavelengths_nm, const InPlaneErrorText& text);

// The same table from readings that leave nodes of the grid unmeasured — a scan through the
// specular peak cannot hold the mirrored angles near retro-reflection (the arms' clearance):
// an unmeasured node holds 0 in every channel, the mark BsdfTable::covers() reads as "not
// measured" (IS-SA and SSDD define no other; bsdf_formats.md), and is listed in `gaps`.
struct InPlaneTable {
  BsdfTable table;
  std::vector<Geometry> gaps;  // in-plane geometries of the unmeasured nodes, by θi then θr
  // "theta_i = 45 deg: theta_r = -80 to -32 deg" per incidence angle with gaps, for a file's
  // header (ASCII).
  std::vector<std::string> gap_ranges() const;
};
InPlaneTable in_plane_table_with_gaps(std::span<const InPlaneReading> readings,
                                      std::vector<double> wavelengths_nm,
                                      const InPlaneErrorText& text);

}  // namespace gonio::twin
