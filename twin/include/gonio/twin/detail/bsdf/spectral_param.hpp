// Parameter values of the spec syntax before they are put on a wavelength grid.
//
// A value is a number ("0.8"), a spectrum of wavelength:value pairs ("400:0.2,700:0.8",
// linearly interpolated onto the grid, constant beyond the ends), or a two-column file
// ("@file.csv": nm and value per line, separated by a comma, semicolon or white space;
// lines starting with '#' ignored).
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "gonio/proto/spectrum.hpp"

namespace gonio::twin::bsdf {

struct RawValue {
  enum class Kind { number, pairs, file };
  Kind kind = Kind::number;
  double number = 0;
  std::vector<std::pair<double, double>> pairs;  // (nm, value), nm strictly increasing
  std::string path;                              // for Kind::file, without the '@'

  static RawValue of(double v) { return RawValue{Kind::number, v, {}, {}}; }
};

// At most this many wavelength:value pairs in one spectrum, inline or from a file.
inline constexpr std::size_t kMaxSpectrumPairs = 100000;
// Spectrum files larger than this are refused (they are two-column text).
inline constexpr std::size_t kMaxSpectrumFileBytes = 16u << 20;

// Parses the text of one value; throws Error(invalid_argument) naming `field`.
RawValue parse_value_text(std::string_view text, const std::string& field);

// Checks pairs: at least one, finite, wavelengths > 0 and strictly increasing.
void check_pairs(const std::vector<std::pair<double, double>>& pairs, const std::string& field);

// Reads a two-column spectrum file. Throws Error(not_found) when it cannot be opened,
// Error(parse_error) naming the line when its content is malformed.
std::vector<std::pair<double, double>> read_spectrum_file(const std::string& path,
                                                          const std::string& field);

// Canonical text of a value: parse_value_text(format_value(v)) gives v back.
std::string format_value(const RawValue& v);

// The value on `grid` (pairs or file contents interpolated linearly, constant beyond the
// ends); `pairs` receives the points the value was made from (a single (0, v) for a number).
std::vector<double> resample(const RawValue& v, const WavelengthGrid& grid,
                             const std::string& field,
                             std::vector<std::pair<double, double>>& pairs);

}  // namespace gonio::twin::bsdf
