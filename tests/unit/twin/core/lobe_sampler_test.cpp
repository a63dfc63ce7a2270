// The truncated bivariate-t lobe density (lobe_sampler.hpp): its conditional CDF inverts,
// its density integrates to one over the aperture, draws stay inside it, and draws follow
// the density (a chi-square test over cells), for lobes centred inside and outside.
#include "gonio/twin/detail/core/lobe_sampler.hpp"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace gonio::twin::detail {
namespace {

TEST(LobeSampler, ConditionalCdfInverts) {
  for (double t = -200; t <= 200; t += 0.0137) {
    const double g = t2_conditional_cdf(t);
    EXPECT_NEAR(t2_conditional_cdf(t2_conditional_inverse(g)), g, 1e-15) << t;
    if (std::abs(t) < 20) {
      EXPECT_NEAR(t2_conditional_inverse(g), t, 1e-9 * (1 + t * t)) << t;
    }
  }
  // G's derivative is (1 + t²)⁻²: a central difference.
  for (double t : {-3.0, -0.4, 0.0, 0.7, 5.0}) {
    const double h = 1e-5;
    EXPECT_NEAR((t2_conditional_cdf(t + h) - t2_conditional_cdf(t - h)) / (2 * h),
                1 / ((1 + t * t) * (1 + t * t)), 1e-8);
  }
}

struct Layout {
  Vec2 centre, scale;
  Aperture aperture;
};

// Narrow and wide in each axis, centred, off-centre, and centred outside the aperture (the
// flank of a lobe whose peak the aperture misses); rectangular and elliptical apertures.
const Layout kLayouts[] = {
    {{0, 0}, {0.01, 0.007}, {0.0183, 0.0367, false}},
    {{0.012, -0.02}, {0.004, 0.003}, {0.0183, 0.0367, false}},
    {{0.03, 0.0}, {0.01, 0.01}, {0.0183, 0.0367, false}},
    {{0.0, 0.0}, {0.2, 0.2}, {0.0183, 0.0367, false}},
    {{0.005, 0.01}, {0.006, 0.004}, {0.0183, 0.0367, true}},
    {{0.025, -0.01}, {0.01, 0.01}, {0.0183, 0.0367, true}},
};

TEST(LobeSampler, DensityIntegratesToOneOverTheAperture) {
  for (const auto& l : kLayouts) {
    const LobeSampler lobe(l.centre, l.scale, l.aperture);
    ASSERT_TRUE(lobe.usable());
    const int n = 1200;
    const double dx = 2 * l.aperture.tx / n, dy = 2 * l.aperture.ty / n;
    double sum = 0;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        sum += lobe.pdf({-l.aperture.tx + (i + 0.5) * dx, -l.aperture.ty + (j + 0.5) * dy});
    EXPECT_NEAR(sum * dx * dy, 1.0, 2e-4) << l.centre.x << " " << l.scale.x;
    EXPECT_EQ(lobe.pdf({1.01 * l.aperture.tx, 0}), 0.0);
    EXPECT_EQ(lobe.pdf({0, -1.01 * l.aperture.ty}), 0.0);
    if (l.aperture.ellipse) {
      EXPECT_EQ(lobe.pdf({0.8 * l.aperture.tx, 0.8 * l.aperture.ty}), 0.0);
    }
  }
}

// 40,000 draws from independent uniforms (a fixed seed) into 8 × 8 cells, against each
// cell's probability by midpoint quadrature of the density: Pearson's χ² with 63 d.o.f.
// stays below its mean plus three standard deviations.
TEST(LobeSampler, DrawsFollowTheDensity) {
  for (const auto& l : kLayouts) {
    const LobeSampler lobe(l.centre, l.scale, l.aperture);
    constexpr int cells = 8, side = 200;
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    std::vector<double> counts(cells * cells, 0.0), expected(cells * cells, 0.0);
    const auto cell_of = [&](Vec2 t) {
      const int i = std::min(cells - 1, static_cast<int>((t.x + l.aperture.tx) / (2 * l.aperture.tx) * cells));
      const int j = std::min(cells - 1, static_cast<int>((t.y + l.aperture.ty) / (2 * l.aperture.ty) * cells));
      return i * cells + j;
    };
    for (int a = 0; a < side; ++a)
      for (int b = 0; b < side; ++b) {
        const double u0 = uniform(rng), u1 = uniform(rng);
        const auto d = lobe.sample(u0, u1);
        ASSERT_TRUE(l.aperture.contains_tangent(d.t)) << d.t.x << " " << d.t.y;
        EXPECT_NEAR(d.pdf, lobe.pdf(d.t), 1e-9 * d.pdf);
        counts[static_cast<std::size_t>(cell_of(d.t))] += 1;
      }
    const int q = 300;
    const double dx = 2 * l.aperture.tx / q, dy = 2 * l.aperture.ty / q;
    for (int i = 0; i < q; ++i)
      for (int j = 0; j < q; ++j) {
        const Vec2 t{-l.aperture.tx + (i + 0.5) * dx, -l.aperture.ty + (j + 0.5) * dy};
        expected[static_cast<std::size_t>(cell_of(t))] += lobe.pdf(t) * dx * dy * side * side;
      }
    double chi2 = 0;
    for (std::size_t k = 0; k < counts.size(); ++k)
      if (expected[k] > 5) chi2 += (counts[k] - expected[k]) * (counts[k] - expected[k]) / expected[k];
    EXPECT_LT(chi2, 63 + 3 * std::sqrt(2 * 63.0)) << l.centre.x << " " << l.scale.x;
  }
}

}  // namespace
}  // namespace gonio::twin::detail
