// Small BSDFs written for the tests, independent of the model family (twin/src/bsdf), so
// that the tabulated formats, the estimator and the renders can be checked against models
// whose values are known in closed form. None of them samples (sample_wi gives nothing,
// pdf is 0): tests sample them through the code under test.
#pragma once

#include <optional>
#include <span>
#include <string>
#include <vector>

#include "gonio/twin/bsdf.hpp"

namespace gonio::test {

using twin::Bsdf;
using twin::BsdfSample;
using twin::DeltaLobe;
using twin::Vec2;
using twin::Vec3;

// A spectral factor so that channels differ: 1 − 0.4·(λ − 400)/300.
double tint(double nm);

// Lambertian reflection (albedo a, tinted) and optionally Lambertian transmission t.
class LambertBsdf final : public Bsdf {
 public:
  LambertBsdf(WavelengthGrid g, double a, double t = 0);
  void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const override;
  std::optional<BsdfSample> sample_wi(const Vec3&, double, Vec2) const override { return {}; }
  double pdf(const Vec3&, const Vec3&) const override { return 0; }
  std::string spec() const override { return "test-lambert"; }

 private:
  double a_, t_;
};

// Reciprocal Phong lobe (exponent n, weight ks) about the mirror direction plus a diffuse
// floor kd, and an optional lobe (kt, nt) about the straight-through direction in
// transmission; `aniso` stretches the reflection lobe along x (makes the model depend on
// absolute azimuth). Tinted like LambertBsdf.
class LobesBsdf final : public Bsdf {
 public:
  LobesBsdf(WavelengthGrid g, double kd, double ks, double n, double kt = 0, double nt = 1,
            double aniso = 0);
  double scalar(const Vec3& wi, const Vec3& wo) const;  // the value before the tint
  void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const override;
  std::optional<BsdfSample> sample_wi(const Vec3&, double, Vec2) const override { return {}; }
  double pdf(const Vec3&, const Vec3&) const override { return 0; }
  std::string spec() const override { return "test-lobes"; }

 private:
  double kd_, ks_, n_, kt_, nt_, aniso_;
};

// An ideal mirror with reflectance r, and an ideal straight-through transmitter with t.
class SpecularBsdf final : public Bsdf {
 public:
  SpecularBsdf(WavelengthGrid g, double r, double t);
  void eval(const Vec3&, const Vec3&, std::span<double> out) const override;
  std::optional<BsdfSample> sample_wi(const Vec3&, double, Vec2) const override { return {}; }
  double pdf(const Vec3&, const Vec3&) const override { return 0; }
  void delta_lobes(const Vec3& wo, std::vector<DeltaLobe>& out) const override;
  bool has_delta() const noexcept override { return true; }
  std::string spec() const override { return "test-specular"; }

 private:
  double r_, t_;
};

}  // namespace gonio::test
