// abg — the Harvey / ABg scatter model of optical engineering (stray-light codes such as
// Zemax, FRED and ASAP; J. E. Harvey, "Light-scattering characteristics of optical
// surfaces", PhD thesis, 1976; J. C. Stover, "Optical Scattering", 3rd ed., §8.3):
//
//   f = A / (B + |β − β0|^g)   sr⁻¹
//
// with β and β0 the projections onto the sample plane (direction cosines) of the scattered
// and of the specular direction: |β − β0| = |wi_xy + wo_xy| for wi, wo pointing away from
// the surface. Symmetric in wi and wo (reciprocal); shift-invariant in direction-cosine
// space, which is the smooth-surface scatter it was made for. B sets the width of the
// rounded top (|β − β0| ≈ B^(1/g)), g the fall-off (g = 0: Lambertian, A/(B + 1)).
//
// Normalisation: cos θ dω is the area element of direction-cosine space, so the total
// integrated scatter at an incidence is the integral of f over the unit disk, largest at
// normal incidence where the lobe is centred: TIS(0) = 2π ∫₀¹ A r / (B + r^g) dr. Parameters
// with TIS(0) > 1 are refused (energy). Domain: an empirical fit of scatter about the
// specular direction; no Fresnel term and no shadowing, so at grazing incidence and far
// from specular it is an extrapolation. Two-sided; sampled in direction-cosine space with a
// radial density tabulated on logarithmic bins.
#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

#include "gonio/twin/detail/bsdf/model.hpp"
#include "gonio/twin/detail/bsdf/sampling.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::twin::bsdf {
namespace {

class Abg final : public Lobe {
 public:
  Abg(const Params& p, const WavelengthGrid& grid)
      : Lobe(grid, p.spec()), a_(p.scalar("A")), b_(p.scalar("B")), g_(p.scalar("g")) {
    tis0_ = 2 * kPi * a_ * radial_integral(1.0);
    if (!(tis0_ <= 1))
      throw Error::invalid("bsdf.abg.A",
                           fmt::format("A = {:g}, B = {:g}, g = {:g} scatter {:.3g} of the light "
                                       "at normal incidence: the total integrated scatter must "
                                       "be ≤ 1 (lower A or raise B)",
                                       a_, b_, g_, tis0_));
    // Radial bins: [0, r1], then logarithmic up to 2, the farthest the specular projection
    // of one hemisphere lies from a direction of the other side of the disk.
    edges_[0] = 0;
    for (int k = 1; k <= kBins; ++k)
      edges_[static_cast<std::size_t>(k)] = 2.0 * std::pow(10.0, -6.0 * (kBins - k) / (kBins - 1));
    double total = 0;
    for (int k = 0; k < kBins; ++k) {
      const double lo = edges_[static_cast<std::size_t>(k)], hi = edges_[static_cast<std::size_t>(k) + 1];
      const double mid = 0.5 * (lo + hi);
      total += weight_[static_cast<std::size_t>(k)] = (hi - lo) * mid / (b_ + std::pow(mid, g_));
    }
    double c = 0;
    for (int k = 0; k < kBins; ++k) {
      weight_[static_cast<std::size_t>(k)] /= total;
      cdf_[static_cast<std::size_t>(k)] = c;
      c += weight_[static_cast<std::size_t>(k)];
    }
    cdf_[kBins] = 1;
  }

  void eval(const Vec3& wi, const Vec3& wo, std::span<double> out) const override {
    const double f = same_hemisphere(wi, wo) ? value(wi, wo) : 0.0;
    for (auto& v : out) v = f;
  }

  std::optional<BsdfSample> sample_wi(const Vec3& wo, double, Vec2 u) const override {
    if (wo.z == 0) return std::nullopt;
    const auto k = static_cast<std::size_t>(
        std::upper_bound(cdf_.begin(), cdf_.begin() + kBins, u.x) - cdf_.begin() - 1);
    const double t = weight_[k] > 0 ? (u.x - cdf_[k]) / weight_[k] : 0.5;
    const double r = edges_[k] + std::clamp(t, 0.0, 1.0) * (edges_[k + 1] - edges_[k]);
    const double phi = 2 * kPi * u.y;
    const double x = -wo.x + r * std::cos(phi), y = -wo.y + r * std::sin(phi);
    const double s2 = x * x + y * y;
    if (s2 >= 1) return std::nullopt;
    Vec3 wi{x, y, std::sqrt(1 - s2)};
    if (wo.z < 0) wi = flip_z(wi);
    const double p = pdf(wo, wi);
    if (!(p > 0)) return std::nullopt;
    return BsdfSample{wi, p};
  }

  double pdf(const Vec3& wo, const Vec3& wi) const override {
    if (!same_hemisphere(wi, wo)) return 0;
    const double r = std::hypot(wi.x + wo.x, wi.y + wo.y);
    if (!(r > 0) || r >= 2) return 0;
    const auto k = static_cast<std::size_t>(
        std::upper_bound(edges_.begin() + 1, edges_.end(), r) - edges_.begin() - 1);
    if (k >= static_cast<std::size_t>(kBins)) return 0;
    const double pr = weight_[k] / (edges_[k + 1] - edges_[k]);  // density of r
    return pr / (2 * kPi * r) * abs_cos_theta(wi);  // per unit disk area, then per sr
  }

  double albedo_hint(const Vec3&) const override { return std::max(tis0_, 1e-6); }

 private:
  static constexpr int kBins = 96;

  double value(const Vec3& wi, const Vec3& wo) const noexcept {
    const double r = std::hypot(wi.x + wo.x, wi.y + wo.y);
    return a_ / (b_ + std::pow(r, g_));
  }

  // ∫₀^R r / (B + r^g) dr on a logarithmic grid in r (the integrand is smooth in ln r).
  double radial_integral(double R) const noexcept {
    constexpr int kN = 4000;
    const double s0 = std::log(1e-12), s1 = std::log(R);
    const double h = (s1 - s0) / kN;
    double sum = 0;
    for (int i = 0; i <= kN; ++i) {
      const double r = std::exp(s0 + i * h);
      const double v = r * r / (b_ + std::pow(r, g_));  // r dr = r² d(ln r)
      sum += (i == 0 || i == kN ? 0.5 : 1.0) * v;
    }
    return sum * h;
  }

  double a_, b_, g_;
  double tis0_ = 0;
  std::array<double, kBins + 1> edges_{}, cdf_{};
  std::array<double, kBins> weight_{};
};

BsdfPtr build_abg(const Params& p, const WavelengthGrid& grid) { return std::make_shared<Abg>(p, grid); }

}  // namespace

const Registrar kAbgRegistered{{"abg",
                             {{"A", false, 1e-9, 100, false, 0.01, " sr⁻¹"},
                              {"B", false, 1e-9, 10, false, 0.001, ""},
                              {"g", false, 0, 4, false, 2, ""}},
                             &build_abg}};

}  // namespace gonio::twin::bsdf
