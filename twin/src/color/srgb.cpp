// XYZ → sRGB for rendered images.
//
// IEC 61966-2-1:1999 (sRGB), the encoding transformation: the matrix from CIE 1931 XYZ
// (display white D65, Y = 1) to linear R, G, B, and the transfer function
// 12.92·c for c ≤ 0.0031308, 1.055·c^(1/2.4) − 0.055 above. These few coefficients are the
// standard's definition, not a measured table.
#include <algorithm>
#include <cmath>

#include "gonio/twin/color.hpp"

namespace gonio::twin {

Rgb xyz_to_linear_srgb(const Xyz& c) {
  return {3.2406 * c.x - 1.5372 * c.y - 0.4986 * c.z,
          -0.9689 * c.x + 1.8758 * c.y + 0.0415 * c.z,
          0.0557 * c.x - 0.2040 * c.y + 1.0570 * c.z};
}

// The standard's decoding matrix (IEC 61966-2-1:1999, §5.2; it is the inverse of the one
// above to the four decimals the standard gives).
Xyz linear_srgb_to_xyz(const Rgb& c) {
  return {0.4124 * c.r + 0.3576 * c.g + 0.1805 * c.b,
          0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b,
          0.0193 * c.r + 0.1192 * c.g + 0.9505 * c.b};
}

double srgb_encode(double linear) {
  const double c = std::clamp(linear, 0.0, 1.0);
  return c <= 0.0031308 ? 12.92 * c : std::min(1.0, 1.055 * std::pow(c, 1 / 2.4) - 0.055);
}

double srgb_decode(double encoded) {
  const double v = std::clamp(encoded, 0.0, 1.0);
  return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

Rgb srgb_encode(const Rgb& linear) {
  return {srgb_encode(linear.r), srgb_encode(linear.g), srgb_encode(linear.b)};
}

}  // namespace gonio::twin
