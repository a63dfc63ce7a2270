// Test support for the tabulated-BSDF tests: small analytic models written here (independent of
// the model family), direction builders for every parametrization, a chi-square goodness
// of fit test, and a scratch directory.
#pragma once

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <span>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/tabulated.hpp"

namespace gonio::twin::tabtest {

inline Vec3 mirror(const Vec3& w) { return {-w.x, -w.y, w.z}; }
inline Vec3 flip(const Vec3& w) { return {w.x, w.y, -w.z}; }
inline Vec3 in_plane_wi(double theta_i_deg) {
  const double t = theta_i_deg * kDegToRad;
  return {-std::sin(t), 0, std::cos(t)};
}
inline Vec3 in_plane_wr(double theta_r_deg) {
  const double t = theta_r_deg * kDegToRad;
  return {std::sin(t), 0, std::cos(t)};
}
inline Vec3 sph(double theta_deg, double phi_deg) {
  return spherical(theta_deg * kDegToRad, phi_deg * kDegToRad);
}

// Directions whose half-difference angles are (θh, φh, θd, φd), degrees (Rusinkiewicz 1998):
// wi is d rotated by θh about y then by φh about z; wo its mirror image about h.
inline void from_half_difference(double th, double ph, double td, double pd, Vec3& wi, Vec3& wo) {
  const Vec3 d = sph(td, pd);
  const double ct = std::cos(th * kDegToRad), st = std::sin(th * kDegToRad);
  const Vec3 t{ct * d.x + st * d.z, d.y, -st * d.x + ct * d.z};
  const double cp = std::cos(ph * kDegToRad), sp = std::sin(ph * kDegToRad);
  wi = {cp * t.x - sp * t.y, sp * t.x + cp * t.y, t.z};
  const Vec3 h = sph(th, ph);
  wo = h * (2 * dot(wi, h)) - wi;
}

// Direction at angle r from the mirror image of wi and azimuth a about it (degrees), in the
// documented frame: azimuth 0 toward the normal, e2 = s × e1.
inline Vec3 about_mirror(const Vec3& wi, double r_deg, double a_deg) {
  const Vec3 m = mirror(wi);
  const double st = std::sqrt(m.x * m.x + m.y * m.y);
  const Vec3 e1 = st < 1e-12 ? Vec3{-1, 0, 0} : normalize(Vec3{0, 0, 1} - m * m.z);
  const Vec3 e2 = cross(m, e1);
  const double r = r_deg * kDegToRad, a = a_deg * kDegToRad;
  return m * std::cos(r) + (e1 * std::cos(a) + e2 * std::sin(a)) * std::sin(r);
}

// A grey specular-parametrization table of `model` (channel 0), zero beyond the horizon.
inline BsdfTable specular_table(const Bsdf& model, const std::vector<double>& ti,
                                const std::vector<double>& r, const std::vector<double>& a,
                                bool bilateral, bool transmission = false) {
  std::vector<double> v;
  std::vector<double> f(model.channels());
  for (const double az : a)
    for (const double rr : r)
      for (const double t : ti) {
        const Vec3 wi{-std::sin(t * kDegToRad), 0, std::cos(t * kDegToRad)};
        Vec3 wo = about_mirror(wi, rr, az);
        double x = 0;
        if (wo.z > 0) {
          if (transmission) wo = flip(wo);
          model.eval(wi, wo, f);
          x = f[0];
        }
        v.push_back(x);
      }
  return BsdfTable(TableParam::specular, {ti, {}, r, a}, {}, v, {bilateral, false});
}

// A grey half-difference table of `model` (channel 0) with the reciprocity reduction.
inline BsdfTable half_difference_table(const Bsdf& model, const std::vector<double>& th,
                                       const std::vector<double>& td,
                                       const std::vector<double>& pd) {
  std::vector<double> v;
  std::vector<double> f(model.channels());
  for (const double p : pd)
    for (const double d : td)
      for (const double h : th) {
        Vec3 wi, wo;
        from_half_difference(h, 0, d, p, wi, wo);
        double x = 0;
        if (wi.z > 0 && wo.z > 0) {
          model.eval(wi, wo, f);
          x = f[0];
        }
        v.push_back(x);
      }
  return BsdfTable(TableParam::half_difference, {th, {}, td, pd}, {}, v, {false, true});
}

inline std::vector<double> steps(double a, double b, double s) {
  std::vector<double> v;
  for (double x = a; x <= b + 1e-9; x += s) v.push_back(x);
  return v;
}

// A spectral factor so that channels differ: 1 − 0.4·(λ − 400)/300.
inline double tint(double nm) { return 1.0 - 0.4 * (nm - 400.0) / 300.0; }

// Lambertian reflection (albedo a, tinted) and optionally Lambertian transmission.
class Lambert final : public Bsdf {
 public:
  Lambert(WavelengthGrid g, double a, double t = 0) : Bsdf(std::move(g)), a_(a), t_(t) {}
  void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const override {
    const double k = wi.z * wo.z > 0 ? a_ : (wi.z * wo.z < 0 ? t_ : 0.0);
    for (std::size_t c = 0; c < out.size(); ++c) out[c] = k * kInvPi * tint(wavelengths()[c]);
  }
  std::optional<BsdfSample> sample_wi(const Vec3&, double, Vec2) const override { return {}; }
  double pdf(const Vec3&, const Vec3&) const override { return 0; }
  std::string spec() const override { return "test-lambert"; }

 private:
  double a_, t_;
};

// Reciprocal Phong lobe about the mirror direction plus a diffuse floor, and an optional
// lobe about the straight-through direction in transmission; `aniso` stretches the
// reflection lobe along x (makes the model depend on absolute azimuth).
class Lobes final : public Bsdf {
 public:
  Lobes(WavelengthGrid g, double kd, double ks, double n, double kt = 0, double nt = 1,
        double aniso = 0)
      : Bsdf(std::move(g)), kd_(kd), ks_(ks), n_(n), kt_(kt), nt_(nt), aniso_(aniso) {}
  double scalar(const Vec3& wi, const Vec3& wo) const {
    if (wi.z * wo.z > 0) {
      const Vec3 a = wi.z > 0 ? wi : Vec3{wi.x, wi.y, -wi.z};
      const Vec3 b = wi.z > 0 ? wo : Vec3{wo.x, wo.y, -wo.z};
      double c = std::max(0.0, dot(b, mirror(a)));
      double v = kd_ * kInvPi + ks_ * (n_ + 2) / (2 * kPi) * std::pow(c, n_);
      if (aniso_ > 0) {
        const double hx = a.x + b.x;
        v *= 1 + aniso_ * hx * hx;
      }
      return v;
    }
    if (wi.z * wo.z < 0 && kt_ > 0) {
      const double c = std::max(0.0, dot(wo, -wi));
      return kt_ * (nt_ + 2) / (2 * kPi) * std::pow(c, nt_);
    }
    return 0;
  }
  void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const override {
    const double v = scalar(wi, wo);
    for (std::size_t c = 0; c < out.size(); ++c) out[c] = v * tint(wavelengths()[c]);
  }
  std::optional<BsdfSample> sample_wi(const Vec3&, double, Vec2) const override { return {}; }
  double pdf(const Vec3&, const Vec3&) const override { return 0; }
  std::string spec() const override { return "test-lobes"; }

 private:
  double kd_, ks_, n_, kt_, nt_, aniso_;
};

// An ideal mirror with reflectance r, and an ideal straight-through transmitter with t.
class Specular final : public Bsdf {
 public:
  Specular(WavelengthGrid g, double r, double t) : Bsdf(std::move(g)), r_(r), t_(t) {}
  void eval(const Vec3&, const Vec3&, std::span<double> out) const override {
    std::fill(out.begin(), out.end(), 0.0);
  }
  std::optional<BsdfSample> sample_wi(const Vec3&, double, Vec2) const override { return {}; }
  double pdf(const Vec3&, const Vec3&) const override { return 0; }
  void delta_lobes(const Vec3& wo, std::vector<DeltaLobe>& out) const override {
    out.clear();
    if (r_ > 0) out.push_back({mirror(wo), std::vector<double>(channels(), r_)});
    if (t_ > 0) out.push_back({-wo, std::vector<double>(channels(), t_)});
  }
  bool has_delta() const noexcept override { return true; }
  std::string spec() const override { return "test-specular"; }

 private:
  double r_, t_;
};

// Regularised upper incomplete gamma Q(a, x), by its series (x < a + 1) or continued fraction
// (Abramowitz & Stegun 6.5.29 and 6.5.31).
inline double gamma_q(double a, double x) {
  if (x <= 0) return 1;
  const double lg = std::lgamma(a);
  if (x < a + 1) {
    double sum = 1 / a, term = sum;
    for (int n = 1; n < 1000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-15) break;
    }
    return 1 - sum * std::exp(-x + a * std::log(x) - lg);
  }
  // Lentz's evaluation of the continued fraction.
  double b = x + 1 - a, c = 1e300, d = 1 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < 1e-300) d = 1e-300;
    c = b + an / c;
    if (std::abs(c) < 1e-300) c = 1e-300;
    d = 1 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1) < 1e-15) break;
  }
  return std::exp(-x + a * std::log(x) - lg) * h;
}

// Chi-square test of `bsdf.sample_wi(wo, …)` against `bsdf.pdf(wo, ·)` over (cos θ, φ) bins
// of the whole sphere; expected counts by midpoint integration of the pdf on a sub-grid.
// The bins' pole is perpendicular to the plane of wo and the normal, so that the mirror
// and straight-through peaks lie on the equator where the sub-grid is fine.
// Returns the p-value; also integrates the pdf and checks each sample's pdf against pdf().
struct ChiSquare {
  double p_value = 0;
  double pdf_integral = 0;
  std::size_t failed_draws = 0;
};

inline ChiSquare chi_square(const Bsdf& bsdf, const Vec3& wo, std::size_t samples,
                            std::uint64_t seed, int n_cos = 20, int n_phi = 24, int sub = 12) {
  ChiSquare res;
  Vec3 pole = cross(Vec3{0, 0, 1}, wo);
  pole = length(pole) < 1e-9 ? Vec3{0, 1, 0} : normalize(pole);
  const Vec3 ax = cross(pole, Vec3{0, 0, 1});
  const Vec3 ay = cross(pole, ax);
  const auto bin_of = [&](const Vec3& w) {
    const double cz = std::clamp(dot(w, pole), -1.0, 1.0);
    double phi = std::atan2(dot(w, ay), dot(w, ax));
    if (phi < 0) phi += 2 * kPi;
    const int i = std::min(n_cos - 1, static_cast<int>((cz + 1) / 2 * n_cos));
    const int j = std::min(n_phi - 1, static_cast<int>(phi / (2 * kPi) * n_phi));
    return static_cast<std::size_t>(i * n_phi + j);
  };
  std::vector<double> observed(static_cast<std::size_t>(n_cos * n_phi), 0.0);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  for (std::size_t k = 0; k < samples; ++k) {
    const auto s = bsdf.sample_wi(wo, uni(rng), {uni(rng), uni(rng)});
    if (!s) {
      ++res.failed_draws;
      continue;
    }
    const double p = bsdf.pdf(wo, s->wi);
    EXPECT_NEAR(s->pdf, p, 1e-9 * std::max(1.0, p)) << "sample pdf differs from pdf()";
    EXPECT_NEAR(length(s->wi), 1.0, 1e-9);
    observed[bin_of(s->wi)] += 1;
  }
  std::vector<double> expected(observed.size(), 0.0);
  const double dz = 2.0 / (n_cos * sub), dp = 2 * kPi / (n_phi * sub);
  for (int i = 0; i < n_cos * sub; ++i) {
    const double z = -1 + (i + 0.5) * dz, r = std::sqrt(std::max(0.0, 1 - z * z));
    for (int j = 0; j < n_phi * sub; ++j) {
      const double phi = (j + 0.5) * dp;
      const Vec3 w = pole * z + (ax * std::cos(phi) + ay * std::sin(phi)) * r;
      const double p = bsdf.pdf(wo, w);
      res.pdf_integral += p * dz * dp;
      expected[static_cast<std::size_t>((i / sub) * n_phi + j / sub)] += p * dz * dp;
    }
  }
  const double drawn = static_cast<double>(samples - res.failed_draws);
  double chi2 = 0, pooled_o = 0, pooled_e = 0;
  int bins = 0;
  for (std::size_t b = 0; b < observed.size(); ++b) {
    const double e = expected[b] * drawn / res.pdf_integral;
    if (e < 5) {
      pooled_o += observed[b];
      pooled_e += e;
      continue;
    }
    chi2 += (observed[b] - e) * (observed[b] - e) / e;
    ++bins;
  }
  if (pooled_e >= 5) {
    chi2 += (pooled_o - pooled_e) * (pooled_o - pooled_e) / pooled_e;
    ++bins;
  }
  res.p_value = bins > 1 ? gamma_q((bins - 1) / 2.0, chi2 / 2) : 1.0;
  return res;
}

// A fresh directory under the system temporary directory, removed at destruction.
class ScratchDir {
 public:
  ScratchDir() {
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() /
            ("gonio-tabulated-" + std::to_string(rd()) + std::to_string(rd()));
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// Runs f and returns the gonio::Error it throws (a test failure when it throws nothing).
template <typename F>
Error error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e;
  }
  ADD_FAILURE() << "no gonio::Error was thrown";
  return Error(Errc::internal, "none");
}

}  // namespace gonio::twin::tabtest
