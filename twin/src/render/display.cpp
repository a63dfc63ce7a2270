// What the eye is shown: exposure, tone map and sRGB; the ΔE00 between two displayed
// spheres and its colour scale.
//
// ΔE is taken between displayed colours (after exposure, tone mapping and clipping to the
// display), in CIELAB against the display white: a difference hidden in a clipped highlight
// is invisible on that display too, and the figure answers "how visible is it here".
#include <algorithm>
#include <cmath>

#include "gonio/proto/error.hpp"
#include "gonio/twin/render.hpp"
#include "render/quantile.hpp"

namespace gonio::twin {
namespace {

// Extended Reinhard (Reinhard et al., "Photographic Tone Reproduction for Digital Images",
// SIGGRAPH 2002, eq. 4) on luminance, chromaticity kept: Y' = Y (1 + Y / W²) / (1 + Y),
// with the white point W = 8 (eight times a white diffuser facing the key light).
constexpr double kReinhardWhite = 8;

Rgb background_linear() {
  return {srgb_decode(kRenderBackground[0] / 255.0), srgb_decode(kRenderBackground[1] / 255.0),
          srgb_decode(kRenderBackground[2] / 255.0)};
}

}  // namespace

Rgb display_rgb(const Xyz& xyz, const RenderOptions& o) {
  Rgb c = xyz_to_linear_srgb({xyz.x * o.exposure, xyz.y * o.exposure, xyz.z * o.exposure});
  if (o.tone_map == ToneMap::reinhard) {
    const double y = xyz.y * o.exposure;
    if (y > 0) {
      const double s = (1 + y / (kReinhardWhite * kReinhardWhite)) / (1 + y);
      c = {c.r * s, c.g * s, c.b * s};
    }
  }
  return {std::clamp(c.r, 0.0, 1.0), std::clamp(c.g, 0.0, 1.0), std::clamp(c.b, 0.0, 1.0)};
}

Lab display_lab(const Rgb& linear_rgb) {
  static const Xyz white = linear_srgb_to_xyz({1, 1, 1});
  return xyz_to_lab(linear_srgb_to_xyz(linear_rgb), white);
}

DeltaEMap delta_e_map(const SphereImage& a, const SphereImage& b, const RenderOptions& o) {
  if (a.size != b.size || a.xyz.size() != b.xyz.size())
    throw Error::invalid("render.spheres", "spheres of different sizes cannot be compared");
  DeltaEMap m;
  m.size = a.size;
  m.delta_e.assign(a.xyz.size(), 0.0f);
  m.coverage.assign(a.xyz.size(), 0.0f);
  const Rgb bg = background_linear();
  const auto composite = [&](const SphereImage& s, std::size_t i) {
    const Rgb c = display_rgb(s.xyz[i], o);
    const double k = s.coverage[i];
    return Rgb{k * c.r + (1 - k) * bg.r, k * c.g + (1 - k) * bg.g, k * c.b + (1 - k) * bg.b};
  };
  std::vector<double> interior;
  double noise = 0;
  for (std::size_t i = 0; i < a.xyz.size(); ++i) {
    const float cov = std::max(a.coverage[i], b.coverage[i]);
    if (cov <= 0) continue;
    m.coverage[i] = cov;
    const double de = delta_e2000(display_lab(composite(a, i)), display_lab(composite(b, i)));
    m.delta_e[i] = static_cast<float>(de);
    if (a.coverage[i] >= 1 && b.coverage[i] >= 1) {
      interior.push_back(de);
      const double rel = std::hypot(a.rel_se[i], b.rel_se[i]);
      const Xyz& x = a.xyz[i];
      const Xyz up{x.x * (1 + rel), x.y * (1 + rel), x.z * (1 + rel)};
      noise += delta_e2000(display_lab(display_rgb(x, o)), display_lab(display_rgb(up, o)));
    }
  }
  m.stats.pixels = interior.size();
  if (!interior.empty()) {
    double s = 0;
    for (double v : interior) s += v;
    m.stats.mean = s / static_cast<double>(interior.size());
    m.stats.noise_mean = std::sqrt(2 / kPi) * noise / static_cast<double>(interior.size());
    m.stats.p95 = quantile(interior, 0.95);
    m.stats.max = *std::max_element(interior.begin(), interior.end());
  }
  return m;
}

std::array<std::uint8_t, 3> delta_e_color(double t) {
  // Dark blue-violet through red and orange to pale yellow: lightness rises monotonically,
  // so the scale reads in grey too. Anchors in sRGB-encoded values.
  static constexpr double kAnchors[][3] = {{0.04, 0.03, 0.12}, {0.32, 0.07, 0.47},
                                           {0.74, 0.18, 0.33}, {0.97, 0.53, 0.10},
                                           {0.99, 0.95, 0.68}};
  constexpr int kLast = 4;
  const double x = std::clamp(std::isfinite(t) ? t : 1.0, 0.0, 1.0) * kLast;
  const int k = std::min(kLast - 1, static_cast<int>(x));
  const double f = x - k;
  std::array<std::uint8_t, 3> out{};
  for (int ch = 0; ch < 3; ++ch)
    out[static_cast<std::size_t>(ch)] = static_cast<std::uint8_t>(std::lround(
        255 * ((1 - f) * kAnchors[k][ch] + f * kAnchors[k + 1][ch])));
  return out;
}

}  // namespace gonio::twin
