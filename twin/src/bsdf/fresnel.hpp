// Fresnel reflectance for unpolarised light: dielectric interfaces (with total internal
// reflection) and conductors with a complex index η + i k.
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>

namespace gonio::twin::bsdf {

// Reflectance at an interface seen from the side of the incident ray, cos_i = cos of the
// angle to the (micro)normal on that side (≥ 0), eta = η_transmitted / η_incident.
// Born & Wolf, Principles of Optics, §1.5.2 (Fresnel equations for r_s and r_p).
inline double fresnel_dielectric(double cos_i, double eta) noexcept {
  cos_i = std::clamp(cos_i, 0.0, 1.0);
  const double sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1.0) return 1.0;  // total internal reflection
  const double cos_t = std::sqrt(1.0 - sin2_t);
  const double r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  const double r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  return 0.5 * (r_p * r_p + r_s * r_s);
}

// Reflectance of a conductor (complex relative index η + i k) seen from a dielectric of
// index 1: the same equations with a complex transmitted cosine (Born & Wolf §14.2).
inline double fresnel_conductor(double cos_i, double eta, double k) noexcept {
  using C = std::complex<double>;
  cos_i = std::clamp(cos_i, 0.0, 1.0);
  const C n(eta, k);
  const double sin2_i = 1.0 - cos_i * cos_i;
  const C cos_t = std::sqrt(C(1.0) - C(sin2_i) / (n * n));
  const C r_s = (C(cos_i) - n * cos_t) / (C(cos_i) + n * cos_t);
  const C r_p = (n * cos_i - cos_t) / (n * cos_i + cos_t);
  const double f = 0.5 * (std::norm(r_s) + std::norm(r_p));
  return std::isfinite(f) ? std::clamp(f, 0.0, 1.0) : 1.0;  // 0/0 only at exact grazing
}

}  // namespace gonio::twin::bsdf
