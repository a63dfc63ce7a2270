// Shared internals of the tabulated family: the frames behind the table parametrizations,
// and a line reader for the text formats that reports errors as "<source>:<line>: ...".
#pragma once

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <istream>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/vec.hpp"

namespace gonio::twin::tab {

inline Vec3 flip_z(const Vec3& w) noexcept { return {w.x, w.y, -w.z}; }

inline double clamp_unit(double c) noexcept { return std::clamp(c, -1.0, 1.0); }

// Azimuth of w in degrees, [0, 360); 0 for directions on the z axis.
inline double azimuth_deg(const Vec3& w) noexcept {
  if (w.x == 0 && w.y == 0) return 0;
  double a = std::atan2(w.y, w.x) * kRadToDeg;
  if (a < 0) a += 360;
  return a >= 360 ? 0 : a;
}

// Azimuth of an incidence direction: on the z axis it is 180°, the limit along the plane of
// measurement (wi = (−sin θ, 0, cos θ)), so that θi → 0 is continuous for the instrument.
inline double incidence_azimuth_deg(const Vec3& w) noexcept {
  return w.x == 0 && w.y == 0 ? 180.0 : azimuth_deg(w);
}

inline double polar_deg(const Vec3& w) noexcept { return std::acos(clamp_unit(w.z)) * kRadToDeg; }

// The frame about the mirror image s of w (w.z >= 0) used by the specular parametrization
// and by the sampler: e1 points from s toward the normal, e2 = s × e1 (counter-clockwise
// seen from +z). At normal incidence s = +z and e1 = −x, the limit along the plane of
// measurement (wi = (−sin θ, 0, cos θ) has s = (sin θ, 0, cos θ)).
struct MirrorFrame {
  Vec3 s, e1, e2;

  static MirrorFrame of(const Vec3& w) noexcept {
    MirrorFrame f;
    f.s = {-w.x, -w.y, w.z};
    const double sin_t = std::sqrt(f.s.x * f.s.x + f.s.y * f.s.y);
    double c = 1, sn = 0;
    if (sin_t > 1e-15) {
      c = f.s.x / sin_t;
      sn = f.s.y / sin_t;
    }
    const double cos_t = f.s.z;
    f.e1 = {-cos_t * c, -cos_t * sn, sin_t};
    f.e2 = cross(f.s, f.e1);
    return f;
  }
  // Direction at angle r from s and azimuth a about it (radians).
  Vec3 direction(double cos_r, double a) const noexcept {
    const double sin_r = std::sqrt(std::max(0.0, 1 - cos_r * cos_r));
    return s * cos_r + (e1 * std::cos(a) + e2 * std::sin(a)) * sin_r;
  }
  // Angle from s (radians) at which the ray of azimuth `a` about s reaches the sample
  // plane: z(r) = cos r·s.z + sin r·(cos a·e1.z + sin a·e2.z) = 0.
  double horizon_radial(double a) const noexcept {
    const double A = s.z, B = std::cos(a) * e1.z + std::sin(a) * e2.z;
    return std::atan2(B, A) + 1.5707963267948966;
  }
  // The direction at (r, a), pulled back onto the horizon (just above it) when r lies beyond:
  // the value a table keeps for nodes below the sample plane.
  Vec3 direction_above(double r, double a) const noexcept {
    return direction(std::cos(std::min(r, horizon_radial(a) - 1e-6)), a);
  }
  // Angle from s (degrees) and azimuth about it (radians, [0, 2π)) of a unit direction.
  void angles(const Vec3& d, double& r_deg, double& a_rad) const noexcept {
    r_deg = std::acos(clamp_unit(dot(d, s))) * kRadToDeg;
    a_rad = std::atan2(dot(d, e2), dot(d, e1));
    if (a_rad < 0) a_rad += 2 * kPi;
    if (a_rad >= 2 * kPi) a_rad = 0;
  }
};

// Half-difference angles of (wi, wo), degrees (Rusinkiewicz 1998 §3): h = (wi + wo)/|…|,
// d = wi rotated by −φh about z, then by −θh about y.
inline void half_difference(const Vec3& wi, const Vec3& wo, double out[4]) noexcept {
  Vec3 h = wi + wo;
  const double len = length(h);
  h = len > 1e-15 ? h / len : Vec3{0, 0, 1};
  const double cos_h = clamp_unit(h.z);
  const double sin_h = std::sqrt(h.x * h.x + h.y * h.y);
  double c = 1, s = 0;
  if (sin_h > 1e-15) {
    c = h.x / sin_h;
    s = h.y / sin_h;
  }
  const Vec3 t{c * wi.x + s * wi.y, -s * wi.x + c * wi.y, wi.z};
  const Vec3 d{cos_h * t.x - sin_h * t.z, t.y, sin_h * t.x + cos_h * t.z};
  out[0] = std::acos(cos_h) * kRadToDeg;
  out[1] = azimuth_deg(h);
  out[2] = std::acos(clamp_unit(d.z)) * kRadToDeg;
  out[3] = azimuth_deg(d);
}

// ---- text parsing ------------------------------------------------------------------------------

inline bool is_space(char c) noexcept { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

inline std::vector<std::string_view> tokens(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const std::size_t b = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > b) out.push_back(line.substr(b, i - b));
  }
  return out;
}

inline bool iequals(std::string_view a, std::string_view b) noexcept {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto lo = [](char ch) { return ch >= 'A' && ch <= 'Z' ? static_cast<char>(ch - 'A' + 'a') : ch; };
    if (lo(a[i]) != lo(b[i])) return false;
  }
  return true;
}

// Reads a text stream line by line, counting lines; every error names the line.
class LineReader {
 public:
  LineReader(std::istream& in, std::string_view source) : in_(in), source_(source) {}

  // Next line without its terminator ('\n' or "\r\n"); false at end of input.
  bool next(std::string& line) {
    if (!std::getline(in_, line)) {
      if (in_.bad()) throw Error(Errc::io_error, fmt::format("{}: read error", source_));
      return false;
    }
    ++line_;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  }
  // Next line that is neither blank nor a '#' comment.
  bool next_content(std::string& line) {
    while (next(line)) {
      const auto t = trimmed(line);
      if (!t.empty() && t.front() != '#') return true;
    }
    return false;
  }
  static std::string_view trimmed(std::string_view s) noexcept {
    while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
    while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
    return s;
  }

  std::size_t line() const noexcept { return line_; }
  std::istream& stream() noexcept { return in_; }
  const std::string& source() const noexcept { return source_; }

  [[noreturn]] void fail(std::string_view message, std::string_view field = {}) const {
    throw Error(Errc::parse_error, fmt::format("{}:{}: {}", source_, line_, message),
                std::string(field));
  }
  [[noreturn]] void unsupported(std::string_view message, std::string_view field = {}) const {
    throw Error(Errc::unsupported, fmt::format("{}:{}: {}", source_, line_, message),
                std::string(field));
  }

  double number(std::string_view tok, std::string_view what) const {
    std::string_view s = tok;
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    double v = 0;
    const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (s.empty() || ec != std::errc{} || ptr != s.data() + s.size())
      fail(fmt::format("{}: '{}' is not a number", what, tok), what);
    if (!std::isfinite(v)) fail(fmt::format("{}: '{}' is not finite", what, tok), what);
    return v;
  }
  std::size_t count(std::string_view tok, std::string_view what, std::size_t max) const {
    std::size_t v = 0;
    const auto [ptr, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
    if (tok.empty() || ec != std::errc{} || ptr != tok.data() + tok.size())
      fail(fmt::format("{}: '{}' is not a count", what, tok), what);
    if (v < 1 || v > max)
      fail(fmt::format("{}: count {} is outside [1, {}]", what, tok, max), what);
    return v;
  }

 private:
  std::istream& in_;
  std::string source_;
  std::size_t line_ = 0;
};

}  // namespace gonio::twin::tab
