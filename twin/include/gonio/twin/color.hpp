// Colorimetry of spectra: CIE XYZ, CIELAB, CIEDE2000 and sRGB for renders.
//
// The CIE tables are not typed into the code: the colour-matching functions and the
// illuminants are read from the CGATS text files of the Debian package colord-data
// (docs/architecture.md §2): <dir>/cmf/CIE1931-2deg-XYZ.cmf, <dir>/cmf/CIE1964-10deg-XYZ.cmf and
// <dir>/illuminant/CIE-<name>.sp. <dir> is the environment variable GONIO_COLORD_DIR
// when set, else the directory configured at build time (/usr/share/colord).
//
// Integration (see twin/colorimetry.md): the tables are interpolated linearly onto the
// spectrum's own wavelength grid (zero outside a table's range) and integrated with the
// trapezoidal rule over that grid; k is chosen so that the perfect reflecting diffuser
// has Y = 100 on the same grid, so the white of every grid maps to L* = 100, a* = b* = 0.
#pragma once

#include <memory>
#include <span>
#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "gonio/proto/spectrum.hpp"

namespace gonio::twin {

// Tristimulus values; Y = 100 for the perfect reflecting diffuser.
struct Xyz {
  double x = 0, y = 0, z = 0;
};

// CIE 1976 L*a*b*.
struct Lab {
  double l = 0, a = 0, b = 0;
};

// Red, green, blue: linear or encoded, as the producing function says.
struct Rgb {
  double r = 0, g = 0, b = 0;
};

enum class ObserverKind {
  cie1931_2deg,   // CIE 1931 standard colorimetric observer (2°)
  cie1964_10deg,  // CIE 1964 supplementary standard colorimetric observer (10°)
};

// "2", "2deg", "cie1931" / "10", "10deg", "cie1964"; throws Error naming `field`.
ObserverKind parse_observer(std::string_view text, std::string_view field = "observer");
std::string_view observer_name(ObserverKind kind) noexcept;  // "CIE 1964 10°"

// The colord-data directory in effect (environment GONIO_COLORD_DIR, else the build default).
std::string colord_dir();

// A colour-matching-function table as read from its file.
class Observer {
 public:
  // Reads <dir>/cmf/<file>. Throws Error(not_found) naming the file and the package,
  // Error(parse_error) naming the file and line.
  static Observer load(ObserverKind kind, const std::string& dir = colord_dir());
  // Loaded once per process and directory; thread-safe.
  static const Observer& get(ObserverKind kind);

  ObserverKind kind() const noexcept { return kind_; }
  const std::vector<double>& wavelengths() const noexcept { return nm_; }
  // Linear interpolation; zero outside the table.
  Xyz at(double nm) const;

 private:
  ObserverKind kind_ = ObserverKind::cie1931_2deg;
  std::vector<double> nm_, x_, y_, z_;
};

// A relative spectral power distribution as read from its file.
class Illuminant {
 public:
  // `name` is the part after "CIE-" in the file name: "D65", "D50", "A", "F11", ...
  // (case-insensitive). Throws Error(not_found) listing the available names.
  static Illuminant load(std::string_view name, const std::string& dir = colord_dir());
  static const Illuminant& get(std::string_view name);
  // Names of every CIE-*.sp file in <dir>/illuminant, sorted.
  static std::vector<std::string> available(const std::string& dir = colord_dir());

  const std::string& name() const noexcept { return name_; }
  const std::vector<double>& wavelengths() const noexcept { return nm_; }
  const std::vector<double>& power() const noexcept { return power_; }
  // Linear interpolation; zero outside the table.
  double at(double nm) const;
  // XYZ of the perfect diffuser integrated on the observer's own 5 nm table (Y = 100).
  Xyz white_point(const Observer& observer) const;

 private:
  std::string name_;
  std::vector<double> nm_, power_;
};

// Weights for one wavelength grid, illuminant and observer, computed once: XYZ of a
// spectrum is then a dot product per component (like the weighting tables of ASTM E308).
class Colorimeter {
 public:
  // Throws Error(invalid_argument, field "wavelengths") when the grid has no overlap with
  // the tables (e.g. an infrared-only grid), so that no Y normalisation exists.
  Colorimeter(WavelengthGrid grid, const Illuminant& illuminant, const Observer& observer);
  // D65 and the 10° observer.
  explicit Colorimeter(WavelengthGrid grid);

  const WavelengthGrid& wavelengths() const noexcept { return grid_; }
  const std::string& illuminant() const noexcept { return illuminant_; }
  ObserverKind observer() const noexcept { return observer_; }

  // Reflectance factors (1 = perfect diffuser), one per channel of the grid.
  Xyz xyz(std::span<const double> reflectance) const;
  // The spectrum must be on this grid (Error naming `field` otherwise).
  Xyz xyz(const Spectrum& s, std::string_view field = "spectrum") const;
  Lab lab(std::span<const double> reflectance) const;
  Lab lab(const Spectrum& s, std::string_view field = "spectrum") const;
  // The perfect diffuser on this grid: Y = 100 exactly, X and Z close to the white point.
  const Xyz& white() const noexcept { return white_; }
  // Per-channel weights w[i] such that XYZ = Σ w[i]·R[i].
  const std::vector<Xyz>& weights() const noexcept { return weights_; }

 private:
  WavelengthGrid grid_;
  std::string illuminant_;
  ObserverKind observer_;
  std::vector<Xyz> weights_;
  Xyz white_;
};

// CIE 15:2004 §8.2.1; `white` is the reference white's XYZ (same scale as `xyz`).
Lab xyz_to_lab(const Xyz& xyz, const Xyz& white);

// Convenience for single spectra (each builds a Colorimeter on the spectrum's grid).
Xyz spectrum_to_xyz(const Spectrum& s, std::string_view illuminant = "D65",
                    ObserverKind observer = ObserverKind::cie1964_10deg);
Lab spectrum_to_lab(const Spectrum& s, std::string_view illuminant = "D65",
                    ObserverKind observer = ObserverKind::cie1964_10deg);

// CIEDE2000 colour difference (CIE 142-2001; Sharma, Wu & Dalal 2005), parametric
// factors kL = kC = kH = 1 unless given.
double delta_e2000(const Lab& lab1, const Lab& lab2, double kl = 1, double kc = 1,
                   double kh = 1);
// ΔE00 as three signed terms whose squares sum to ΔE00²: the lightness term, and the chroma
// and hue terms with the rotation term RT·ΔC'·ΔH' folded in (a Cholesky factor of their
// quadratic form). A smooth residual for least squares where ΔE00 itself has a kink at 0.
std::array<double, 3> delta_e2000_terms(const Lab& lab1, const Lab& lab2);
// ΔE00 between the colours of two reflectance spectra (grids may differ).
double delta_e2000(const Spectrum& s1, const Spectrum& s2, std::string_view illuminant = "D65",
                   ObserverKind observer = ObserverKind::cie1964_10deg);

// Per-channel weights, summing to 1, whose weighted mean of a reflectance (or BRDF) spectrum is
// its luminance factor Y/100 for D65 and the 10° observer; empty when the grid has fewer than
// two channels or misses the visible (then a plain mean is the only sensible grey).
std::vector<double> luminance_weights(const std::vector<double>& wavelengths_nm);
// Per-channel weights of X, Y and Z (D65, 10° observer) scaled so that Y of a non-selective
// spectrum equals its value: a reflectance spectrum's XYZ/100. Empty under the same
// conditions as luminance_weights (then only grey can be written).
std::optional<std::array<std::vector<double>, 3>> xyz_weights(const std::vector<double>& wavelengths_nm);

// sRGB (IEC 61966-2-1:1999). XYZ on the 0..1 scale (Y = 1 for the display white, D65,
// CIE 1931 2° observer) to linear RGB; values outside [0, 1] are kept.
Rgb xyz_to_linear_srgb(const Xyz& xyz);
// The inverse: linear sRGB to XYZ (Y = 1 for the display white).
Xyz linear_srgb_to_xyz(const Rgb& rgb);
// The sRGB transfer function, one component; input clamped to [0, 1].
double srgb_encode(double linear);
double srgb_decode(double encoded);
Rgb srgb_encode(const Rgb& linear);

}  // namespace gonio::twin
