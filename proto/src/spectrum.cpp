#include "gonio/proto/spectrum.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"
#include "gonio/proto/text.hpp"

namespace gonio {

WavelengthGrid::WavelengthGrid(std::vector<double> nm, std::string_view field) : nm_(std::move(nm)) {
  const std::string f(field);
  if (nm_.empty()) throw Error::invalid(f, "needs at least one wavelength");
  if (nm_.size() > kMaxChannels)
    throw Error(Errc::out_of_range,
                fmt::format("{} has {} channels, more than the limit {}", f, nm_.size(),
                            kMaxChannels),
                f);
  for (std::size_t i = 0; i < nm_.size(); ++i) {
    if (!(nm_[i] >= kMinNm && nm_[i] <= kMaxNm))
      throw Error::out_of_range(fmt::format("{}[{}]", f, i), nm_[i], kMinNm, kMaxNm, " nm");
    if (i > 0 && !(nm_[i] > nm_[i - 1]))
      throw Error::invalid(fmt::format("{}[{}]", f, i),
                           fmt::format("{:g} nm does not increase on {:g} nm", nm_[i],
                                       nm_[i - 1]));
  }
}

WavelengthGrid WavelengthGrid::parse(std::string_view text, std::string_view field) {
  return WavelengthGrid(text::parse_value_list(field, text, kMaxChannels), field);
}

std::string WavelengthGrid::to_string() const { return text::format_value_list(nm_); }

Spectrum::Spectrum(WavelengthGrid grid, std::vector<double> v, std::vector<double> u)
    : wavelengths(std::move(grid)), values(std::move(v)), std_uncertainty(std::move(u)) {
  if (std_uncertainty.empty()) std_uncertainty.assign(values.size(), 0.0);
  validate();
}

double Spectrum::at(double nm) const {
  return interpolate_linear(wavelengths.values(), values, {nm}).front();
}

void Spectrum::validate(std::string_view field) const {
  const auto f = [field](std::string_view k) { return join_field(field, k); };
  if (values.size() != wavelengths.size())
    throw Error::invalid(f("values"), fmt::format("has {} entries for {} wavelengths",
                                                    values.size(), wavelengths.size()));
  if (std_uncertainty.size() != wavelengths.size())
    throw Error::invalid(f("std_uncertainty"),
                         fmt::format("has {} entries for {} wavelengths", std_uncertainty.size(),
                                     wavelengths.size()));
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i]))
      throw Error::invalid(fmt::format("{}[{}]", f("values"), i), "is not finite");
    if (!(std_uncertainty[i] >= 0) || !std::isfinite(std_uncertainty[i]))
      throw Error::invalid(fmt::format("{}[{}]", f("std_uncertainty"), i),
                           "must be finite and >= 0");
  }
}

std::vector<double> interpolate_linear(const std::vector<double>& x, const std::vector<double>& y,
                                       const std::vector<double>& x_new) {
  std::vector<double> out(x_new.size(), 0.0);
  if (x.empty()) return out;
  for (std::size_t k = 0; k < x_new.size(); ++k) {
    const double t = x_new[k];
    if (t <= x.front()) {
      out[k] = y.front();
    } else if (t >= x.back()) {
      out[k] = y.back();
    } else {
      const auto it = std::upper_bound(x.begin(), x.end(), t);
      const auto i = static_cast<std::size_t>(it - x.begin());
      const double w = (t - x[i - 1]) / (x[i] - x[i - 1]);
      out[k] = y[i - 1] + w * (y[i] - y[i - 1]);
    }
  }
  return out;
}

void to_json(nlohmann::json& j, const WavelengthGrid& w) { j = w.values(); }

void from_json(const nlohmann::json& j, WavelengthGrid& w) {
  if (j.is_string()) {
    w = WavelengthGrid::parse(j.get<std::string>(), "");
    return;
  }
  if (!j.is_array())
    throw Error::invalid("", "expected \"400:700:10\" or an array of numbers");
  std::vector<double> nm;
  for (std::size_t i = 0; i < j.size(); ++i)
    nm.push_back(json_util::get_as<double>(j[i], fmt::format("[{}]", i)));
  w = WavelengthGrid(std::move(nm), "");
}

void to_json(nlohmann::json& j, const Spectrum& s) {
  j = nlohmann::json{{"wavelengths_nm", s.wavelengths.values()},
                     {"values", s.values},
                     {"std_uncertainty", s.std_uncertainty}};
}

void from_json(const nlohmann::json& j, Spectrum& s) {
  json_util::ObjectReader r(j, "");
  s.wavelengths = r.required<WavelengthGrid>("wavelengths_nm");
  s.values = r.required<std::vector<double>>("values");
  s.std_uncertainty = r.optional<std::vector<double>>("std_uncertainty", {});
  r.finish();
  if (s.std_uncertainty.empty()) s.std_uncertainty.assign(s.values.size(), 0.0);
  s.validate("");
}

}  // namespace gonio
