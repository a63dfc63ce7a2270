// The instrument's optics as geometry: arm frames, angular apertures and the footprints of
// the beam and of the receiver's field on the sample plane.
//
// Each arm has a frame (axis a from the sample centre toward the arm, t in the arm's plane
// of measurement, p across it). A direction inside an angular aperture is parametrised by
// tangent-plane coordinates: ω = normalize(a + tx·t + ty·p); a rectangular aperture of full
// angles (A, B) is |tx| ≤ tan(A/2), |ty| ≤ tan(B/2), and dω = cos³γ dtx dty (γ = angle to a).
//
// A cross-section (the beam, or the receiver's entrance pupil) is a shape in the plane
// through the sample centre perpendicular to the axis. A sample-plane point x belongs to
// it for a ray direction ω when x projected along ω onto that plane falls inside: on the
// sample plane that is a parallelogram (an ellipse for elliptical shapes), so the region
// seen and lit for given directions is an intersection of convex sets whose area we get
// exactly by clipping (ellipses are 64-gons with the ellipse's area).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <utility>

#include "gonio/twin/instrument.hpp"
#include "gonio/twin/vec.hpp"

namespace gonio::twin::detail {

struct ArmFrame {
  Vec3 a, t, p;
};

// Frame of an arm pointing along `axis`, with azimuth phi (radians) of its plane of
// measurement; p = (−sin φ, cos φ, 0) is defined even at normal incidence.
inline ArmFrame arm_frame(const Vec3& axis, double phi) noexcept {
  const Vec3 p{-std::sin(phi), std::cos(phi), 0};
  return {axis, normalize(cross(p, axis)), p};
}

struct Aperture {
  double tx = 0, ty = 0;  // tangent of the half angles
  bool ellipse = false;

  static Aperture from(const Extent& full_angles_deg, ApertureShape shape) noexcept {
    return {std::tan(0.5 * full_angles_deg.in_plane * kDegToRad),
            std::tan(0.5 * full_angles_deg.perpendicular * kDegToRad),
            shape == ApertureShape::ellipse};
  }
  double tangent_area() const noexcept { return ellipse ? kPi * tx * ty : 4 * tx * ty; }
  bool contains_tangent(double x, double y) const noexcept {
    if (ellipse) return (x / tx) * (x / tx) + (y / ty) * (y / ty) <= 1;
    return std::abs(x) <= tx && std::abs(y) <= ty;
  }
  bool contains_tangent(Vec2 t) const noexcept { return contains_tangent(t.x, t.y); }
};

// Uniform point in the unit square mapped onto an aperture's tangent region.
inline Vec2 aperture_point(const Aperture& ap, double u0, double u1) noexcept {
  if (!ap.ellipse) return {(2 * u0 - 1) * ap.tx, (2 * u1 - 1) * ap.ty};
  // Shirley–Chiu concentric mapping of the square onto the disk (area preserving).
  const double a = 2 * u0 - 1, b = 2 * u1 - 1;
  if (a == 0 && b == 0) return {0, 0};
  double r, phi;
  if (std::abs(a) > std::abs(b)) {
    r = a, phi = (kPi / 4) * (b / a);
  } else {
    r = b, phi = (kPi / 2) - (kPi / 4) * (a / b);
  }
  return {r * std::cos(phi) * ap.tx, r * std::sin(phi) * ap.ty};
}

struct ApertureDirection {
  Vec3 w;
  double cos_gamma3 = 0;  // cos³γ: dω = cos³γ dt
};

inline ApertureDirection direction_from_tangent(const ArmFrame& f, Vec2 t) noexcept {
  const double inv = 1.0 / std::sqrt(1 + t.x * t.x + t.y * t.y);
  return {(f.a + t.x * f.t + t.y * f.p) * inv, inv * inv * inv};
}

// Tangent coordinates of ω in the frame; false when ω points away from the arm.
inline bool tangent_of(const ArmFrame& f, const Vec3& w, Vec2& out) noexcept {
  const double c = dot(w, f.a);
  if (c <= 0) return false;
  out = {dot(w, f.t) / c, dot(w, f.p) / c};
  return true;
}

// A convex polygon on the sample plane with a fixed capacity. Vertex storage is left
// uninitialised and only the first n vertices are ever copied: clipping runs several times
// per Monte Carlo point, and touching the whole capacity would dominate its cost.
struct Polygon {
  struct Point {
    double x, y;  // no initialisers on purpose (see above)
  };
  static constexpr std::size_t kMax = 160;
  Point v[kMax];
  std::size_t n = 0;

  Polygon() noexcept {}  // NOLINT: vertices are written before they are read
  Polygon(const Polygon& o) noexcept : n(o.n) { std::copy(o.v, o.v + o.n, v); }
  Polygon& operator=(const Polygon& o) noexcept {
    n = o.n;
    std::copy(o.v, o.v + o.n, v);
    return *this;
  }

  static Polygon rectangle(double half_x, double half_y) noexcept {
    Polygon p;
    p.v[0] = {-half_x, -half_y};
    p.v[1] = {half_x, -half_y};
    p.v[2] = {half_x, half_y};
    p.v[3] = {-half_x, half_y};
    p.n = 4;
    return p;
  }
  double area() const noexcept {
    if (n < 3) return 0;
    double s = 0;
    for (std::size_t i = 0, j = n - 1; i < n; j = i++) s += v[j].x * v[i].y - v[i].x * v[j].y;
    return 0.5 * std::abs(s);
  }
};

// Writes into `out` the part of `in` where g·x ≤ c (Sutherland–Hodgman against one
// half-plane); returns false, leaving `out` as it was, when nothing is cut away.
inline bool clip_into(const Polygon& in, Polygon& out, Vec2 g, double c) noexcept {
  if (in.n == 0) return false;
  std::size_t m = 0;
  bool all_inside = true;
  for (std::size_t i = 0; i < in.n; ++i) {
    const auto a = in.v[i];
    const auto b = in.v[i + 1 == in.n ? 0 : i + 1];
    const double da = g.x * a.x + g.y * a.y - c;
    const double db = g.x * b.x + g.y * b.y - c;
    if (da <= 0) {
      out.v[m++] = a;
    } else {
      all_inside = false;
    }
    if ((da < 0 && db > 0) || (da > 0 && db < 0)) {
      const double s = da / (da - db);
      out.v[m++] = {a.x + s * (b.x - a.x), a.y + s * (b.y - a.y)};
    }
    if (m + 2 > Polygon::kMax) break;  // cannot happen for convex inputs within capacity
  }
  if (all_inside) return false;
  out.n = m;
  return true;
}

// Keeps the part of `poly` where g·x ≤ c.
inline void clip(Polygon& poly, Vec2 g, double c) noexcept {
  Polygon out;
  if (clip_into(poly, out, g, c)) poly = out;
}

// The 64-gon that stands for an ellipse in unit coordinates: its sides' directions
// (cos θk, sin θk) and the distance r that gives it the ellipse's area.
struct EqualAreaGon {
  static constexpr int kSides = 64;
  std::array<std::pair<double, double>, kSides> sides;
  double r;
};
inline const EqualAreaGon& equal_area_gon() noexcept {
  static const EqualAreaGon gon = [] {
    EqualAreaGon g{};
    for (int k = 0; k < EqualAreaGon::kSides; ++k) {
      const double th = 2 * kPi * k / EqualAreaGon::kSides;
      g.sides[static_cast<std::size_t>(k)] = {std::cos(th), std::sin(th)};
    }
    g.r = std::sqrt(kPi / (EqualAreaGon::kSides * std::tan(kPi / EqualAreaGon::kSides)));
    return g;
  }();
  return gon;
}

// The footprint on the sample plane of a cross-section of an arm, for rays along ω.
class Footprint {
 public:
  Footprint() = default;
  Footprint(const ArmFrame& f, const Extent& size_mm, ApertureShape shape)
      : frame_(f), hx_(0.5 * size_mm.in_plane), hy_(0.5 * size_mm.perpendicular),
        ellipse_(shape == ApertureShape::ellipse) {}

  // Clips `poly` to the footprint for rays along ω (ω·a > 0).
  void clip_to(Polygon& poly, const Vec3& w) const noexcept {
    // X(x) = x·t − (ω·t)(x·a)/(ω·a) on the plane z = 0, likewise Y with p.
    const double wa = dot(w, frame_.a);
    const double kt = dot(w, frame_.t) / wa, kp = dot(w, frame_.p) / wa;
    const Vec2 gt{frame_.t.x - frame_.a.x * kt, frame_.t.y - frame_.a.y * kt};
    const Vec2 gp{frame_.p.x - frame_.a.x * kp, frame_.p.y - frame_.a.y * kp};
    if (!ellipse_) {
      clip(poly, gt, hx_);
      clip(poly, {-gt.x, -gt.y}, hx_);
      clip(poly, gp, hy_);
      clip(poly, {-gp.x, -gp.y}, hy_);
      return;
    }
    // Ellipse (X/hx)² + (Y/hy)² ≤ 1 as a circumscribed-and-shrunk 64-gon of equal area:
    // half-planes cos(θk)·X/hx + sin(θk)·Y/hy ≤ r with r chosen for equal area.
    const auto& gon = equal_area_gon();
    // A polygon inside the 64-gon's inscribed circle (radius r) is not clipped by any side:
    // the common case of a beam footprint well inside the field, 64 passes saved.
    bool inside = true;
    for (std::size_t i = 0; i < poly.n && inside; ++i) {
      const double X = (gt.x * poly.v[i].x + gt.y * poly.v[i].y) / hx_;
      const double Y = (gp.x * poly.v[i].x + gp.y * poly.v[i].y) / hy_;
      inside = X * X + Y * Y <= gon.r * gon.r;
    }
    if (inside) return;
    // Ping-pong between two buffers: a side that cuts swaps them, none copies back and forth.
    Polygon spare;
    Polygon* cur = &poly;
    Polygon* next = &spare;
    for (const auto& [c, s] : gon.sides) {
      const double cx = c / hx_, cy = s / hy_;
      if (clip_into(*cur, *next, {cx * gt.x + cy * gp.x, cx * gt.y + cy * gp.y}, gon.r))
        std::swap(cur, next);
    }
    if (cur != &poly) poly = *cur;
  }
  // Whether the sample-plane point x lies in the footprint for rays along ω.
  bool contains(const Vec2& x, const Vec3& w) const noexcept {
    const double wa = dot(w, frame_.a);
    const double X = x.x * frame_.t.x + x.y * frame_.t.y -
                     dot(w, frame_.t) * (x.x * frame_.a.x + x.y * frame_.a.y) / wa;
    const double Y = x.x * frame_.p.x + x.y * frame_.p.y -
                     dot(w, frame_.p) * (x.x * frame_.a.x + x.y * frame_.a.y) / wa;
    if (ellipse_) return (X / hx_) * (X / hx_) + (Y / hy_) * (Y / hy_) <= 1;
    return std::abs(X) <= hx_ && std::abs(Y) <= hy_;
  }
  double cross_section_area() const noexcept { return ellipse_ ? kPi * hx_ * hy_ : 4 * hx_ * hy_; }
  // Uniform point of the cross-section, in the arm frame's (t, p) coordinates.
  Vec2 point(double u0, double u1) const noexcept {
    return aperture_point(Aperture{hx_, hy_, ellipse_}, u0, u1);
  }
  const ArmFrame& frame() const noexcept { return frame_; }

 private:
  ArmFrame frame_{};
  double hx_ = 0, hy_ = 0;
  bool ellipse_ = false;
};

}  // namespace gonio::twin::detail
