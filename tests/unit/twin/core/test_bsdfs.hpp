// Minimal BSDFs for the estimator tests, independent of the model family under test
// elsewhere: a Lambertian reflector/transmitter, an ideal mirror and a normalised Phong
// lobe around the mirror direction (Lafortune & Willems 1994), each with exact sampling.
#pragma once

#include <cmath>
#include <memory>
#include <string>

#include "gonio/twin/bsdf.hpp"

namespace gonio::twin::testing {

inline Vec3 cosine_hemisphere(Vec2 u) {
  const double r = std::sqrt(u.x), phi = 2 * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0, 1 - u.x))};
}

class TestLambert final : public Bsdf {
 public:
  TestLambert(WavelengthGrid g, double albedo, bool transmit = false)
      : Bsdf(std::move(g)), albedo_(albedo), transmit_(transmit) {}
  void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const override {
    const bool ok = transmit_ ? wi.z * wo.z < 0 : wi.z * wo.z > 0;
    for (auto& v : out) v = ok ? albedo_ * kInvPi : 0.0;
  }
  std::optional<BsdfSample> sample_wi(const Vec3& wo, double, Vec2 u) const override {
    Vec3 w = cosine_hemisphere(u);
    const bool up = transmit_ ? wo.z < 0 : wo.z > 0;
    if (!up) w.z = -w.z;
    return BsdfSample{w, std::abs(w.z) * kInvPi};
  }
  double pdf(const Vec3& wo, const Vec3& wi) const override {
    const bool ok = transmit_ ? wi.z * wo.z < 0 : wi.z * wo.z > 0;
    return ok ? std::abs(wi.z) * kInvPi : 0.0;
  }
  std::string spec() const override { return "test-lambert"; }

 private:
  double albedo_;
  bool transmit_;
};

class TestMirror final : public Bsdf {
 public:
  TestMirror(WavelengthGrid g, double r) : Bsdf(std::move(g)), r_(r) {}
  void eval(const Vec3&, const Vec3&, std::span<double> out) const override {
    for (auto& v : out) v = 0;
  }
  std::optional<BsdfSample> sample_wi(const Vec3&, double, Vec2) const override {
    return std::nullopt;
  }
  double pdf(const Vec3&, const Vec3&) const override { return 0; }
  void delta_lobes(const Vec3& wo, std::vector<DeltaLobe>& out) const override {
    out.assign(1, DeltaLobe{{-wo.x, -wo.y, wo.z}, std::vector<double>(channels(), r_)});
  }
  bool has_delta() const noexcept override { return true; }
  std::string spec() const override { return "test-mirror"; }

 private:
  double r_;
};

// Reciprocal lobe f = k (n+2)/(2π) cos^n α, α the angle between wi and the mirror image of
// wo. Sampling draws wi with pdf (n+1)/(2π) cos^n α around the mirror direction.
class TestPhong final : public Bsdf {
 public:
  TestPhong(WavelengthGrid g, double k, double n) : Bsdf(std::move(g)), k_(k), n_(n) {}
  void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const override {
    double v = 0;
    if (wi.z > 0 && wo.z > 0) {
      const double c = dot(wi, Vec3{-wo.x, -wo.y, wo.z});
      if (c > 0) v = k_ * (n_ + 2) / (2 * kPi) * std::pow(c, n_);
    }
    // A gentle spectral slope so channels differ.
    for (std::size_t i = 0; i < out.size(); ++i)
      out[i] = v * (1.0 - 0.3 * static_cast<double>(i) / static_cast<double>(out.size()));
  }
  std::optional<BsdfSample> sample_wi(const Vec3& wo, double, Vec2 u) const override {
    const Vec3 m{-wo.x, -wo.y, wo.z};
    const double cos_a = std::pow(1 - u.x, 1 / (n_ + 1));
    const double sin_a = std::sqrt(std::max(0.0, 1 - cos_a * cos_a));
    const double phi = 2 * kPi * u.y;
    const Frame f = Frame::from_normal(m);
    const Vec3 wi = f.to_world({sin_a * std::cos(phi), sin_a * std::sin(phi), cos_a});
    if (wi.z <= 0) return std::nullopt;
    return BsdfSample{wi, pdf(wo, wi)};
  }
  double pdf(const Vec3& wo, const Vec3& wi) const override {
    if (wi.z <= 0 || wo.z <= 0) return 0;
    const double c = dot(wi, Vec3{-wo.x, -wo.y, wo.z});
    return c > 0 ? (n_ + 1) / (2 * kPi) * std::pow(c, n_) : 0;
  }
  std::string spec() const override { return "test-phong"; }

 private:
  double k_, n_;
};

}  // namespace gonio::twin::testing
