// The test BSDFs of test_bsdfs.hpp.
#include "gonio/test/test_bsdfs.hpp"

#include <algorithm>
#include <cmath>

namespace gonio::test {
namespace {

Vec3 mirror(const Vec3& w) { return {-w.x, -w.y, w.z}; }

}  // namespace

double tint(double nm) { return 1.0 - 0.4 * (nm - 400.0) / 300.0; }

LambertBsdf::LambertBsdf(WavelengthGrid g, double a, double t) : Bsdf(std::move(g)), a_(a), t_(t) {}

void LambertBsdf::eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const {
  const double k = wi.z * wo.z > 0 ? a_ : (wi.z * wo.z < 0 ? t_ : 0.0);
  for (std::size_t c = 0; c < out.size(); ++c) out[c] = k * twin::kInvPi * tint(wavelengths()[c]);
}

LobesBsdf::LobesBsdf(WavelengthGrid g, double kd, double ks, double n, double kt, double nt,
                     double aniso)
    : Bsdf(std::move(g)), kd_(kd), ks_(ks), n_(n), kt_(kt), nt_(nt), aniso_(aniso) {}

double LobesBsdf::scalar(const Vec3& wi, const Vec3& wo) const {
  if (wi.z * wo.z > 0) {
    const Vec3 a = wi.z > 0 ? wi : Vec3{wi.x, wi.y, -wi.z};
    const Vec3 b = wi.z > 0 ? wo : Vec3{wo.x, wo.y, -wo.z};
    const double c = std::max(0.0, dot(b, mirror(a)));
    double v = kd_ * twin::kInvPi + ks_ * (n_ + 2) / (2 * twin::kPi) * std::pow(c, n_);
    if (aniso_ > 0) {
      const double hx = a.x + b.x;
      v *= 1 + aniso_ * hx * hx;
    }
    return v;
  }
  if (wi.z * wo.z < 0 && kt_ > 0) {
    const double c = std::max(0.0, dot(wo, -wi));
    return kt_ * (nt_ + 2) / (2 * twin::kPi) * std::pow(c, nt_);
  }
  return 0;
}

void LobesBsdf::eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const {
  const double v = scalar(wi, wo);
  for (std::size_t c = 0; c < out.size(); ++c) out[c] = v * tint(wavelengths()[c]);
}

SpecularBsdf::SpecularBsdf(WavelengthGrid g, double r, double t) : Bsdf(std::move(g)), r_(r), t_(t) {}

void SpecularBsdf::eval(const Vec3&, const Vec3&, std::span<double> out) const {
  std::fill(out.begin(), out.end(), 0.0);
}

void SpecularBsdf::delta_lobes(const Vec3& wo, std::vector<DeltaLobe>& out) const {
  out.clear();
  if (r_ > 0) out.push_back({mirror(wo), std::vector<double>(channels(), r_)});
  if (t_ > 0) out.push_back({-wo, std::vector<double>(channels(), t_)});
}

}  // namespace gonio::test
