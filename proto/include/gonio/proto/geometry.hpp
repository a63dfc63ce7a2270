// Measurement geometry in the sample frame of docs/architecture.md §2.
//
// Sample plane z = 0, normal +z, plane of measurement x–z. Angles in degrees.
//   incident direction (toward the source): ωi = (−sin θi cos φi, −sin θi sin φi, cos θi)
//   receiving direction (toward receiver):  ωr = ( sin θr cos φr,  sin θr sin φr, cos θr)
// θr is signed in the plane of measurement: θr = θi is specular, θr = −θi is
// retro-reflection, |θr| > 90° is transmission (ωr below the sample).
// Aspecular angle = θi − θr, so "45as15" is θi = 45°, θr = 30°.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace gonio {

struct Geometry {
  double theta_i = 0;  // incidence angle, [0, 90) degrees
  double phi_i = 0;    // incidence azimuth, [-180, 180] degrees
  double theta_r = 0;  // signed receiving angle, [-180, 180] degrees
  double phi_r = 0;    // receiving azimuth, [-180, 180] degrees

  static constexpr double kMaxIncidence = 89.9;

  static Geometry in_plane(double theta_i, double theta_r) { return {theta_i, 0, theta_r, 0}; }
  // θr = θi − aspecular
  static Geometry from_aspecular(double theta_i, double aspecular) {
    return {theta_i, 0, theta_i - aspecular, 0};
  }
  // Parses "45as15", "45as-15" (any θi and aspecular angle) or "45/-30" (θi/θr).
  static Geometry parse(std::string_view text);
  // The ASTM E2175/E2539 multi-angle set: 45as-15, 45as15, 45as25, 45as45, 45as75, 45as110.
  static const std::vector<std::pair<std::string, Geometry>>& astm_multi_angle();

  bool in_measurement_plane() const noexcept { return phi_i == 0 && phi_r == 0; }
  bool is_transmission() const noexcept;
  // θi − θr; meaningful for in-plane reflection geometries.
  double aspecular() const noexcept { return theta_i - theta_r; }
  std::array<double, 3> incident_direction() const noexcept;
  std::array<double, 3> receiving_direction() const noexcept;

  // Throws Error(out_of_range) naming `<field>.theta_i` etc.
  void validate(std::string_view field = "geometry") const;

  // "45/30" or "45/30 az 0/90"
  std::string to_string() const;

  friend bool operator==(const Geometry&, const Geometry&) = default;
};

// Expands the grid syntax "in=45;out=-80:80:1[;az-in=0;az-out=0,90]" (also "as=" for
// aspecular angles in place of "out=") into the Cartesian product of the lists.
// Keys may repeat in no order; unknown keys are rejected. Each geometry is validated.
std::vector<Geometry> parse_geometry_grid(std::string_view text, std::size_t max_count = 100000);

void to_json(nlohmann::json& j, const Geometry& g);
void from_json(const nlohmann::json& j, Geometry& g);

}  // namespace gonio
