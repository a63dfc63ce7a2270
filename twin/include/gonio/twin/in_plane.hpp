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

}  // namespace gonio::twin
