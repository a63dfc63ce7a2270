#include "render/scene.hpp"

#include <algorithm>
#include <cmath>

namespace gonio::twin::render {
namespace {

double smoothstep(double e0, double e1, double x) {
  const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

}  // namespace

bool Scene::Box::contains(const Vec3& w) const noexcept {
  if (w.y < y0 || w.y > y1) return false;
  const double a = std::atan2(w.x, w.z);
  return a >= a0 && a <= a1;
}

Scene::Scene(const Lighting& l) : kind_(l.environment), level_(l.environment_level) {
  const double th = l.light_theta * kDegToRad, ph = l.light_phi * kDegToRad;
  key_ = {std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)};
  if (l.light_size > 0) {
    // A disc of angular radius δ with irradiance 1 at normal incidence: L·π·sin²δ = E.
    const double d = l.light_size * kDegToRad;
    point_ = false;
    disc_ = true;
    disc_cos_ = std::cos(d);
    disc_radiance_ = 1 / (std::sin(d) * std::sin(d));
    disc_pdf_ = 1 / (2 * kPi * (1 - disc_cos_));
  }
  if (kind_ == EnvironmentKind::studio) {
    // Two softboxes, left-high key fill and a right rim, as a product photographer sets
    // them; radiance in units of the environment level.
    const auto deg = [](double v) { return v * kDegToRad; };
    boxes_.push_back({deg(-115), deg(-55), std::sin(deg(15)), std::sin(deg(55)), 8 * level_});
    boxes_.push_back({deg(60), deg(100), std::sin(deg(-10)), std::sin(deg(35)), 4 * level_});
    if (!(level_ > 0)) boxes_.clear();
  }
  double total = 0;
  std::vector<double> power;
  if (disc_) power.push_back(disc_radiance_ / disc_pdf_);
  for (const auto& b : boxes_) power.push_back(b.radiance * b.solid_angle());
  for (double p : power) total += p;
  double acc = 0;
  for (double p : power) pick_.push_back(acc += p / total);
  if (!pick_.empty()) pick_.back() = 1;
}

double Scene::environment(const Vec3& w) const noexcept {
  switch (kind_) {
    case EnvironmentKind::none: return 0;
    case EnvironmentKind::uniform: return level_;
    case EnvironmentKind::sky: {
      // Hazy sky: a darker ground (30 %) rising smoothly through the horizon (±20°) to the
      // sky, which darkens toward the zenith (55 % there). Smooth on purpose: the estimator's
      // control variate removes the dome's gradient across a lobe, not its curvature.
      const double t = smoothstep(-0.35, 0.35, w.y);
      const double up = std::max(0.0, w.y);
      return level_ * (0.3 + 0.7 * t) * (1 - 0.45 * up * up);
    }
    case EnvironmentKind::studio:
      // A dim backdrop, lighter toward the top.
      return level_ * (0.08 + 0.12 * smoothstep(-1, 1, w.y));
  }
  return 0;
}

double Scene::emitted(const Vec3& w) const noexcept {
  double l = 0;
  if (disc_ && dot(w, key_) >= disc_cos_) l += disc_radiance_;
  for (const auto& b : boxes_)
    if (b.contains(w)) l += b.radiance;
  return l;
}

double Scene::emitter_pdf(const Vec3& w) const noexcept {
  double p = 0, prev = 0;
  std::size_t k = 0;
  if (disc_) {
    if (dot(w, key_) >= disc_cos_) p += pick_[0] * disc_pdf_;
    prev = pick_[0];
    k = 1;
  }
  for (const auto& b : boxes_) {
    if (b.contains(w)) p += (pick_[k] - prev) / b.solid_angle();
    prev = pick_[k++];
  }
  return p;
}

EmitterSample Scene::sample_emitter(double u_pick, Vec2 u) const noexcept {
  const auto k = static_cast<std::size_t>(
      std::lower_bound(pick_.begin(), pick_.end(), u_pick) - pick_.begin());
  const std::size_t idx = std::min(k, pick_.size() - 1);
  Vec3 w;
  if (disc_ && idx == 0) {
    // Uniform in the cone: cos θ uniform in [cos δ, 1].
    const double c = 1 - u.x * (1 - disc_cos_);
    const Vec3 local = {std::sqrt(std::max(0.0, 1 - c * c)) * std::cos(2 * kPi * u.y),
                        std::sqrt(std::max(0.0, 1 - c * c)) * std::sin(2 * kPi * u.y), c};
    w = Frame::from_normal(key_).to_world(local);
  } else {
    const Box& b = boxes_[idx - (disc_ ? 1 : 0)];
    const double a = b.a0 + u.x * (b.a1 - b.a0), y = b.y0 + u.y * (b.y1 - b.y0);
    const double s = std::sqrt(std::max(0.0, 1 - y * y));
    w = {s * std::sin(a), y, s * std::cos(a)};
  }
  return {w, emitted(w), emitter_pdf(w)};
}

}  // namespace gonio::twin::render
