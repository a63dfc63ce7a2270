// Small 3-vector and 2-vector value types for the twin's math (radians inside).
#pragma once

#include <cmath>
#include <numbers>

namespace gonio::twin {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kInvPi = 1.0 / std::numbers::pi;
inline constexpr double kDegToRad = std::numbers::pi / 180.0;
inline constexpr double kRadToDeg = 180.0 / std::numbers::pi;

struct Vec2 {
  double x = 0, y = 0;
};

struct Vec3 {
  double x = 0, y = 0, z = 0;

  constexpr Vec3 operator+(const Vec3& o) const noexcept { return {x + o.x, y + o.y, z + o.z}; }
  constexpr Vec3 operator-(const Vec3& o) const noexcept { return {x - o.x, y - o.y, z - o.z}; }
  constexpr Vec3 operator-() const noexcept { return {-x, -y, -z}; }
  constexpr Vec3 operator*(double s) const noexcept { return {x * s, y * s, z * s}; }
  constexpr Vec3 operator/(double s) const noexcept { return {x / s, y / s, z / s}; }
  constexpr Vec3& operator+=(const Vec3& o) noexcept { return *this = *this + o; }
  friend constexpr Vec3 operator*(double s, const Vec3& v) noexcept { return v * s; }
};

constexpr double dot(const Vec3& a, const Vec3& b) noexcept {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
constexpr Vec3 cross(const Vec3& a, const Vec3& b) noexcept {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double length(const Vec3& v) noexcept { return std::sqrt(dot(v, v)); }
inline Vec3 normalize(const Vec3& v) noexcept { return v / length(v); }

// Mirror image of `w` about the normal `n` (both unit, pointing away from the surface).
constexpr Vec3 reflect(const Vec3& w, const Vec3& n) noexcept { return 2 * dot(w, n) * n - w; }

// Local shading frame helpers: the sample frame has its normal on +z.
inline double abs_cos_theta(const Vec3& w) noexcept { return std::abs(w.z); }
inline bool same_hemisphere(const Vec3& a, const Vec3& b) noexcept { return a.z * b.z > 0; }

// Spherical direction from polar angle θ (from +z) and azimuth φ, radians.
inline Vec3 spherical(double theta, double phi) noexcept {
  const double s = std::sin(theta);
  return {s * std::cos(phi), s * std::sin(phi), std::cos(theta)};
}

// Orthonormal basis (t, b, n) around unit n (Duff et al. 2017, "Building an Orthonormal
// Basis, Revisited").
struct Frame {
  Vec3 t, b, n;

  static Frame from_normal(const Vec3& n) noexcept {
    const double sign = std::copysign(1.0, n.z);
    const double a = -1.0 / (sign + n.z);
    const double bb = n.x * n.y * a;
    return {{1.0 + sign * n.x * n.x * a, sign * bb, -sign * n.x}, {bb, sign + n.y * n.y * a, -n.y}, n};
  }
  Vec3 to_local(const Vec3& v) const noexcept { return {dot(v, t), dot(v, b), dot(v, n)}; }
  Vec3 to_world(const Vec3& v) const noexcept { return t * v.x + b * v.y + n * v.z; }
};

}  // namespace gonio::twin
