// The lights of a sphere render, in the camera's world frame (view +z toward the camera,
// image right +x, up +y). Values are relative radiance L_rel = π·L / E (E: the key light's
// irradiance on a surface facing it), so a pixel is ∫ f·cos θi·L_rel dω.
//
// Split for the estimator (twin/rendering.md): a smooth dome (`environment`, continuous over
// the sphere of directions; the control variate uses it) and emitters with edges (the key
// light's disc, the studio's softboxes), sampled explicitly and combined with BSDF sampling
// by multiple importance sampling. A key light of size 0 is a point light, evaluated
// exactly.
#pragma once

#include <optional>
#include <vector>

#include "gonio/twin/render.hpp"

namespace gonio::twin::render {

struct EmitterSample {
  Vec3 w;            // world direction toward the emitter
  double radiance;   // L_rel along w
  double pdf;        // solid-angle density of the emitter mixture at w (emitter_pdf)
};

class Scene {
 public:
  explicit Scene(const Lighting& lighting);

  const Vec3& key() const noexcept { return key_; }
  bool point_light() const noexcept { return point_; }
  // The smooth dome along world direction w.
  double environment(const Vec3& w) const noexcept;
  bool has_environment() const noexcept { return kind_ != EnvironmentKind::none; }
  // Emitters' radiance along w (0 outside them).
  double emitted(const Vec3& w) const noexcept;
  bool has_emitters() const noexcept { return !boxes_.empty() || disc_; }
  // One direction from the emitters, chosen in proportion to their power.
  EmitterSample sample_emitter(double u_pick, Vec2 u) const noexcept;
  double emitter_pdf(const Vec3& w) const noexcept;

 private:
  // A softbox: azimuth a = atan2(x, z) in [a0, a1], height y = sin(elevation) in [y0, y1]
  // — uniform in solid angle when a and y are.
  struct Box {
    double a0, a1, y0, y1, radiance;
    double solid_angle() const noexcept { return (a1 - a0) * (y1 - y0); }
    bool contains(const Vec3& w) const noexcept;
  };

  EnvironmentKind kind_;
  double level_;
  Vec3 key_;
  bool point_ = true, disc_ = false;
  double disc_cos_ = 1, disc_radiance_ = 0, disc_pdf_ = 0;
  std::vector<Box> boxes_;
  std::vector<double> pick_;  // cumulative probabilities: disc (if any), then boxes
};

}  // namespace gonio::twin::render
