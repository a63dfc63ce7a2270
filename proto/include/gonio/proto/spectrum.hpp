// Wavelength grids and spectra with per-channel standard uncertainty (k = 1).
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace gonio {

// Strictly increasing wavelengths in nm, within [kMinNm, kMaxNm].
class WavelengthGrid {
 public:
  static constexpr double kMinNm = 200;
  static constexpr double kMaxNm = 2500;
  static constexpr std::size_t kMaxChannels = 512;

  WavelengthGrid() = default;
  // Throws Error naming `field` when values are out of range or not increasing.
  explicit WavelengthGrid(std::vector<double> nm, std::string_view field = "wavelengths");
  // "400:700:10", "450,550,650", "555"
  static WavelengthGrid parse(std::string_view text, std::string_view field = "wavelengths");
  static WavelengthGrid visible() { return parse("400:700:10"); }

  std::size_t size() const noexcept { return nm_.size(); }
  bool empty() const noexcept { return nm_.empty(); }
  double operator[](std::size_t i) const noexcept { return nm_[i]; }
  const std::vector<double>& values() const noexcept { return nm_; }
  auto begin() const noexcept { return nm_.begin(); }
  auto end() const noexcept { return nm_.end(); }
  std::string to_string() const;

  friend bool operator==(const WavelengthGrid&, const WavelengthGrid&) = default;

 private:
  std::vector<double> nm_;
};

// Values on a wavelength grid with the standard uncertainty of each channel.
struct Spectrum {
  WavelengthGrid wavelengths;
  std::vector<double> values;
  std::vector<double> std_uncertainty;  // same size as values; zeros when unknown

  Spectrum() = default;
  Spectrum(WavelengthGrid grid, std::vector<double> v, std::vector<double> u = {});

  std::size_t size() const noexcept { return values.size(); }
  // Linear interpolation (constant beyond the ends).
  double at(double nm) const;
  // Checks sizes and finiteness; uncertainties must be >= 0.
  void validate(std::string_view field = "spectrum") const;

  friend bool operator==(const Spectrum&, const Spectrum&) = default;
};

// Linear interpolation of (x, y) samples at `x_new`, constant extrapolation.
std::vector<double> interpolate_linear(const std::vector<double>& x, const std::vector<double>& y,
                                       const std::vector<double>& x_new);

void to_json(nlohmann::json& j, const WavelengthGrid& w);
void from_json(const nlohmann::json& j, WavelengthGrid& w);
void to_json(nlohmann::json& j, const Spectrum& s);
void from_json(const nlohmann::json& j, Spectrum& s);

}  // namespace gonio
