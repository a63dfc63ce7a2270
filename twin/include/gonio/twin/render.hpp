// Sphere renders: two spheres side by side, left with one BSDF (the true one), right with
// another (the virtually measured, tabulated one), as in the founding paper's visual
// analysis. Used by `gonio-twin render`.
//
// Scene: orthographic camera looking down −z at unit spheres; a directional light (its
// spectrum CIE D65) plus a dim uniform environment of the same spectrum. Radiance is
// computed per wavelength channel of each BSDF, converted to XYZ (D65, CIE 1931 2°) and to
// sRGB. Units: the light's irradiance on a surface facing it is 1, so a white Lambertian
// surface facing the light has luminance 1 (before exposure); the environment's radiance
// is `environment` times that of the same white surface, i.e. a white Lambertian sphere
// lit by the environment alone has luminance `environment`.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/plot.hpp"

namespace gonio::twin {

struct RenderOptions {
  int size = 320;                // pixels per sphere square; image is 2·size wide
  double light_theta = 45;       // degrees between the light and the view direction
  double light_phi = 135;        // degrees in the image plane, from +x (right) toward up
  double environment = 0.1;      // uniform environment level (see above), >= 0
  int samples = 16;              // per pixel: sub-pixel positions and environment draws
  double exposure = 1;           // linear scale before sRGB encoding
  std::uint64_t seed = 1;
  unsigned threads = 0;          // 0: hardware concurrency
  std::string left_caption = "true BSDF";
  std::string right_caption = "measured BSDF";

  // Throws Error(out_of_range) naming the option ("render.size") and its range.
  void validate() const;
};

struct Rendering {
  Image image;                   // 2·size × (size + caption band), sRGB
  int size = 0;                  // sphere square size; sphere k occupies x ∈ [k·size, (k+1)·size)
  double radius = 0;             // sphere radius in pixels, centred in its square
  std::vector<float> luminance;  // size·2·size: Y per pixel of the sphere squares, before
                                 // exposure, averaged over the pixel (sub-pixel samples that
                                 // miss the sphere count 0); row-major like `image`
  std::array<std::uint8_t, 3> background{};  // colour of pixels that show no sphere

  float luminance_at(int x, int y) const {
    return luminance.at(static_cast<std::size_t>(y) * 2 * static_cast<std::size_t>(size) +
                        static_cast<std::size_t>(x));
  }
};

// Deterministic for the options (seed). Both spheres use the same random numbers, so
// differences between them come from the BSDFs, not from noise. Each BSDF may have its own
// wavelength grid; a grid without visible wavelengths renders in grey (channel mean).
Rendering render_spheres(const Bsdf& left, const Bsdf& right, const RenderOptions& options = {});

}  // namespace gonio::twin
