// XYZ and CIELAB of reflectance spectra (CIE 15:2004 §7, §8).
//
//   X = k Σ R(λi) S(λi) x̄(λi) Δi,  Y, Z alike,  k = 100 / Σ S(λi) ȳ(λi) Δi
//
// S and x̄ȳz̄ are the colord-data tables interpolated linearly at the grid's wavelengths
// (zero outside a table), Δi the trapezoidal weight of channel i: half the distance
// between its neighbours, half the adjacent interval at either end (1 for a one-channel
// grid). Computing k on the same grid makes the perfect diffuser Y = 100 exactly and its
// L*a*b* (100, 0, 0) whatever the grid; a grid coarser than the tables' 5 nm loses some
// accuracy (twin/colorimetry.md quantifies it).
#include <cmath>
#include <optional>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/color.hpp"

namespace gonio::twin {

Colorimeter::Colorimeter(WavelengthGrid grid, const Illuminant& illuminant,
                         const Observer& observer)
    : grid_(std::move(grid)), illuminant_(illuminant.name()), observer_(observer.kind()) {
  const std::size_t n = grid_.size();
  if (n == 0) throw Error::invalid("wavelengths", "needs at least one wavelength");
  weights_.resize(n);
  double norm = 0;
  for (std::size_t i = 0; i < n; ++i) {
    double d = 1;  // a single channel stands for itself
    if (n > 1) {
      const double lo = i == 0 ? grid_[0] : grid_[i - 1];
      const double hi = i + 1 == n ? grid_[n - 1] : grid_[i + 1];
      d = 0.5 * (hi - lo);
    }
    const double s = illuminant.at(grid_[i]) * d;
    const Xyz c = observer.at(grid_[i]);
    weights_[i] = {s * c.x, s * c.y, s * c.z};
    norm += s * c.y;
  }
  if (!(norm > 0))
    throw Error::invalid(
        "wavelengths",
        fmt::format("grid {} nm does not overlap illuminant {} and the {} observer, so it has "
                    "no colour",
                    grid_.to_string(), illuminant_, observer_name(observer_)));
  const double k = 100.0 / norm;
  for (auto& w : weights_) {
    w = {w.x * k, w.y * k, w.z * k};
    white_ = {white_.x + w.x, white_.y + w.y, white_.z + w.z};
  }
}

Colorimeter::Colorimeter(WavelengthGrid grid)
    : Colorimeter(std::move(grid), Illuminant::get("D65"),
                  Observer::get(ObserverKind::cie1964_10deg)) {}

Xyz Colorimeter::xyz(std::span<const double> reflectance) const {
  if (reflectance.size() != weights_.size())
    throw Error::invalid("reflectance", fmt::format("has {} values for {} wavelengths",
                                                    reflectance.size(), weights_.size()));
  Xyz out;
  for (std::size_t i = 0; i < weights_.size(); ++i) {
    out.x += weights_[i].x * reflectance[i];
    out.y += weights_[i].y * reflectance[i];
    out.z += weights_[i].z * reflectance[i];
  }
  return out;
}

Xyz Colorimeter::xyz(const Spectrum& s, std::string_view field) const {
  if (s.wavelengths != grid_)
    throw Error::invalid(join_field(field, "wavelengths_nm"),
                         fmt::format("grid {} differs from the colorimeter's grid {}",
                                     s.wavelengths.to_string(), grid_.to_string()));
  if (s.values.size() != grid_.size())
    throw Error::invalid(join_field(field, "values"),
                         fmt::format("has {} entries for {} wavelengths", s.values.size(),
                                     grid_.size()));
  return xyz(std::span<const double>(s.values));
}

Lab Colorimeter::lab(std::span<const double> reflectance) const {
  return xyz_to_lab(xyz(reflectance), white_);
}

Lab Colorimeter::lab(const Spectrum& s, std::string_view field) const {
  return xyz_to_lab(xyz(s, field), white_);
}

Lab xyz_to_lab(const Xyz& xyz, const Xyz& white) {
  // CIE 15:2004 eq. 8.3–8.7: f(t) = t^(1/3) above (6/29)³, its linear continuation below.
  constexpr double e = 6.0 / 29.0;
  const auto f = [](double t) {
    return t > e * e * e ? std::cbrt(t) : t / (3 * e * e) + 4.0 / 29.0;
  };
  const double fx = f(xyz.x / white.x);
  const double fy = f(xyz.y / white.y);
  const double fz = f(xyz.z / white.z);
  return {116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)};
}

Xyz spectrum_to_xyz(const Spectrum& s, std::string_view illuminant, ObserverKind observer) {
  return Colorimeter(s.wavelengths, Illuminant::get(illuminant), Observer::get(observer))
      .xyz(s);
}

Lab spectrum_to_lab(const Spectrum& s, std::string_view illuminant, ObserverKind observer) {
  return Colorimeter(s.wavelengths, Illuminant::get(illuminant), Observer::get(observer))
      .lab(s);
}

double delta_e2000(const Spectrum& s1, const Spectrum& s2, std::string_view illuminant,
                   ObserverKind observer) {
  return delta_e2000(spectrum_to_lab(s1, illuminant, observer),
                     spectrum_to_lab(s2, illuminant, observer));
}

std::vector<double> luminance_weights(const std::vector<double>& wavelengths_nm) {
  if (wavelengths_nm.size() < 2) return {};
  std::optional<Colorimeter> c;
  try {
    c.emplace(WavelengthGrid(wavelengths_nm));
  } catch (const Error&) {
    return {};  // no overlap with the colour-matching functions
  }
  std::vector<double> w;
  double sum = 0;
  for (const auto& x : c->weights()) {
    w.push_back(x.y);
    sum += x.y;
  }
  if (!(sum > 0)) return {};
  for (auto& v : w) v /= sum;
  return w;
}

std::optional<std::array<std::vector<double>, 3>> xyz_weights(const std::vector<double>& wavelengths_nm) {
  if (wavelengths_nm.size() < 2) return std::nullopt;
  std::optional<Colorimeter> c;
  try {
    c.emplace(WavelengthGrid(wavelengths_nm));
  } catch (const Error&) {
    return std::nullopt;  // no overlap with the colour-matching functions
  }
  std::array<std::vector<double>, 3> w;
  for (const auto& x : c->weights()) {
    w[0].push_back(x.x / 100);
    w[1].push_back(x.y / 100);
    w[2].push_back(x.z / 100);
  }
  return w;
}

}  // namespace gonio::twin
