// A master reference: a sample's radiance factor as one instrument measured it in the plane
// of measurement, kept as the catalogue that later scans are judged against
// (docs/decision-rule.md, "Master references").
//
// The points lie on curves, one per incidence angle, over the aspecular angle x = θi − θr:
// the specular frame, in which a gloss lobe stays where it is from one incidence to the next
// and the curve is smooth through the peak. Between the nodes of a curve β is linear in x,
// exactly what the table (`table()`: a bilateral specular table, radial angle |x|, azimuth 0
// on the normal's side, 180 beyond the specular direction) gives the twin.
//
// The interpolation's uncertainty is the error bound of linear interpolation,
// |β(x) − L(x)| ≤ (x − a)(b − x)/2 · max|β''| (a, b the bracketing nodes), with β'' taken
// from the second divided differences of the two node triples around the interval (the one
// ending at a and the one starting at b) and their largest value used: zero at a node, largest
// mid-interval. It is tested by leaving each inner node out (`leave_one_out`): the curve
// without it predicts it, with u from the remaining nodes alone.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "gonio/proto/geometry.hpp"
#include "gonio/twin/tabulated.hpp"

namespace gonio::twin {

struct MasterPoint {
  double theta_i = 0, theta_r = 0;  // degrees, in the plane of measurement
  std::vector<double> beta, u;      // per channel; u standard (k = 1), >= 0
  friend bool operator==(const MasterPoint&, const MasterPoint&) = default;
};

// β at a geometry with the master's own u there and the interpolation's, per channel.
struct MasterEstimate {
  std::vector<double> beta, u_measured, u_interpolation;
  // √(u_measured² + u_interpolation²) / β per channel (0 where β is 0).
  std::vector<double> u_relative() const;
};

// Leave-one-out: every inner node of every curve predicted from the curve without it.
struct LooReport {
  std::size_t residuals = 0;       // nodes × channels left out
  std::size_t within_1u = 0, within_2u = 0;
  double rms_z = 0;                // RMS of (left out − predicted) / u
  double fraction(double k) const;  // k = 1 or 2: the share within k·u
};

class Master {
 public:
  static constexpr double kIncidenceMatch = 0.05;  // degrees: the same incidence angle
  static constexpr std::size_t kMinNodes = 3;      // per curve: a curvature needs three

  Master() = default;
  // Repeats of one geometry are merged (mean β, u of the mean). Throws Error naming
  // `field` ("reference.points[3].beta") for a channel count that differs, a value that is
  // not finite or negative, a geometry out of the plane or in transmission, or a curve with
  // fewer than kMinNodes distinct geometries.
  Master(std::vector<double> wavelengths_nm, std::vector<MasterPoint> points,
         const std::string& field = "points");

  const std::vector<double>& wavelengths() const noexcept { return nm_; }
  std::size_t channels() const noexcept { return nm_.size(); }
  // The merged points, by incidence and then aspecular angle.
  std::vector<MasterPoint> points() const;
  std::vector<double> incidences() const;

  // Empty when the master covers g; otherwise why not, in words.
  std::string uncovered(const Geometry& g) const;
  // Throws Error(out_of_range, field "geometry") when g is not covered.
  MasterEstimate at(const Geometry& g) const;
  LooReport leave_one_out() const;

  // The same points with other β and u (an instrument correction).
  Master with_values(std::vector<std::vector<double>> beta, std::vector<std::vector<double>> u) const;
  // f = β/π on a bilateral specular table (radial |x|, azimuth 0 and 180), channels on the
  // master's wavelengths; beyond a curve's ends its end value.
  BsdfTable table() const;

 private:
  struct Curve {
    double theta_i = 0;
    std::vector<double> x;                       // aspecular angles, increasing
    std::vector<std::vector<double>> beta, u;    // per node, per channel
  };
  const Curve* curve_at(double theta_i) const noexcept;
  // At x on curve c, node `skip` left out (none: c.x.size()). x inside the nodes used.
  MasterEstimate estimate(const Curve& c, double x, std::size_t skip) const;
  std::vector<double> clamped(const Curve& c, double x) const;

  std::vector<double> nm_;
  std::vector<Curve> curves_;  // by incidence
};

}  // namespace gonio::twin
