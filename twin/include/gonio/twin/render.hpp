// Sphere renders for judging a measurement by eye, as in the founding paper's visual
// analysis: spheres side by side — the true BSDF, the virtually measured one and, when
// there is a fit, the instrument-corrected one — plus maps of the per-pixel CIEDE2000
// difference of each against the first. Used by `gonio-twin render`; twin/rendering.md
// describes the scene, the estimator and the figures.
//
// Scene: orthographic camera looking down −z at a unit sphere (image right +x, up +y); a
// key light (a point light, or a disc of angular radius `light_size`) and an environment
// (none, uniform, a procedural sky or studio softboxes). Every light has the spectrum of
// CIE D65, so a pixel's CIE XYZ (D65, 1931 2°, white aligned on the sRGB white) is the
// integral of the BSDF projected on three colour channels.
//
// Units: a pixel value is π·radiance / E, E the key light's irradiance on a surface facing
// it — a white diffuser facing the key light has Y = 1. The environment level is the
// radiance of the uniform environment (and of the sky's horizon) in the same unit: a white
// diffuser inside a uniform environment of level L has Y = L.
//
// Noise: each pixel is estimated from independent samples until its standard error is at
// most `rel_se` of its luminance (pixels darker than kLitFloor get the same absolute
// target), so spheres rendered with the same options carry the same noise whatever their
// BSDF. Every pixel draws its own random numbers from (seed, x, y): the result does not
// depend on the thread count.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "gonio/proto/enum_text.hpp"
#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/color.hpp"
#include "gonio/twin/plot.hpp"

namespace gonio::twin {

enum class EnvironmentKind { none, uniform, sky, studio };
inline constexpr EnumNames<EnvironmentKind, 4> kEnvironmentKindNames{{
    {EnvironmentKind::none, "none"},
    {EnvironmentKind::uniform, "uniform"},
    {EnvironmentKind::sky, "sky"},
    {EnvironmentKind::studio, "studio"},
}};
constexpr const auto& enum_names(EnvironmentKind) { return kEnvironmentKindNames; }

enum class ToneMap { clip, reinhard };
inline constexpr EnumNames<ToneMap, 2> kToneMapNames{{
    {ToneMap::clip, "clip"},
    {ToneMap::reinhard, "reinhard"},
}};
constexpr const auto& enum_names(ToneMap) { return kToneMapNames; }

struct Lighting {
  double light_theta = 45;   // degrees between the key light and the view direction
  double light_phi = 135;    // degrees in the image plane, from +x (right) toward up
  double light_size = 2;     // angular radius of the key light, degrees; 0: a point light
  EnvironmentKind environment = EnvironmentKind::sky;
  double environment_level = 0.25;

  // Throws Error(out_of_range) naming the field ("render.light_size") and its range.
  void validate() const;
};

struct RenderOptions {
  int size = 320;              // pixels per sphere panel (square)
  Lighting lighting;
  double rel_se = 0.01;        // per-pixel target: s.e. of the luminance / luminance
  int min_samples = 32;        // per pixel, also the batch size between convergence checks
  int max_samples = 4096;      // per pixel; pixels that hit it are reported as unconverged
  bool color = true;          // false: the luminance alone, in grey
  double exposure = 1;         // linear scale before tone mapping
  ToneMap tone_map = ToneMap::clip;
  double delta_e_max = 5;      // top of the ΔE00 colour scale
  std::uint64_t seed = 1;
  unsigned threads = 0;        // 0: hardware concurrency

  // Throws Error(out_of_range) naming the field ("render.rel_se") and its range.
  void validate() const;
};

// Pixels with Y below this (after exposure) are outside the lit region: their noise target
// is absolute, rel_se × kLitFloor, and they are left out of the noise report.
inline constexpr double kLitFloor = 0.02;

// Noise actually reached over the lit pixels fully on the sphere.
struct NoiseReport {
  std::size_t lit_pixels = 0;
  double median_rel_se = 0, p95_rel_se = 0, max_rel_se = 0;
  double converged_fraction = 1;  // of lit pixels at or below the target
  double mean_samples = 0;        // per pixel on the sphere
};

// One sphere, linear (before exposure and tone mapping), row-major, row 0 at the top.
struct SphereImage {
  int size = 0;
  double radius = 0;                 // sphere radius in pixels, centred in the panel
  std::vector<Xyz> xyz;              // per pixel, at the pixel centre's surface point
  std::vector<float> coverage;       // fraction of the pixel covered by the sphere
  std::vector<float> rel_se;         // s.e. of Y / max(Y, kLitFloor / exposure)
  std::vector<std::uint32_t> samples;
  NoiseReport noise;
  double seconds = 0;      // wall
  double cpu_seconds = 0;  // the process's CPU time over the render (every thread)

  std::size_t index(int x, int y) const {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(size) +
           static_cast<std::size_t>(x);
  }
  double luminance_at(int x, int y) const { return xyz[index(x, y)].y; }
};

// Renders one sphere. Deterministic for the options (seed), whatever options.threads.
SphereImage render_sphere(const Bsdf& bsdf, const RenderOptions& options);

// The displayed colour of a linear XYZ: exposure, tone map, clipped to the sRGB gamut,
// linear sRGB in [0, 1] (encode with srgb_encode for 8-bit output).
Rgb display_rgb(const Xyz& xyz, const RenderOptions& options);
// CIELAB of a displayed linear sRGB colour against the display white (D65, Y = 1).
Lab display_lab(const Rgb& linear_rgb);

struct DeltaEStats {
  std::size_t pixels = 0;  // pixels fully on both spheres
  double mean = 0, p95 = 0, max = 0;
  // The mean ΔE00 the two renders' own noise would give between identical BSDFs: per pixel
  // the ΔE of a luminance change of one combined standard error, times √(2/π) (the mean of
  // |N(0, 1)|). A mean close to it says the spheres differ by noise alone.
  double noise_mean = 0;
};

// Per-pixel CIEDE2000 between the displayed colours of two spheres (same size), both
// composited on the background; stats over pixels fully on the sphere.
struct DeltaEMap {
  int size = 0;
  std::vector<float> delta_e;  // per pixel; 0 off the spheres
  std::vector<float> coverage;
  DeltaEStats stats;
};
DeltaEMap delta_e_map(const SphereImage& reference, const SphereImage& other,
                      const RenderOptions& options);

// The ΔE colour scale: t in [0, 1] → sRGB-encoded colour, dark to light.
std::array<std::uint8_t, 3> delta_e_color(double t);

// The figure: spheres left to right, then the ΔE maps, then a scale bar; a caption under
// every panel. Throws Error(invalid_argument) when sizes or counts disagree.
struct Panels {
  std::vector<const SphereImage*> spheres;
  std::vector<std::string> sphere_captions;
  std::vector<const DeltaEMap*> maps;
  std::vector<std::string> map_captions;
};
inline constexpr std::array<std::uint8_t, 3> kRenderBackground{40, 40, 44};
Image compose_panels(const Panels& panels, const RenderOptions& options);

// Convenience for the common case: renders every BSDF, maps each one after the first
// against the first, and composes the figure.
struct Comparison {
  std::vector<SphereImage> spheres;
  std::vector<DeltaEMap> maps;  // maps[k]: spheres[k + 1] against spheres[0]
  Image image;
};
Comparison render_comparison(const std::vector<const Bsdf*>& bsdfs,
                             const std::vector<std::string>& captions,
                             const RenderOptions& options);

}  // namespace gonio::twin
