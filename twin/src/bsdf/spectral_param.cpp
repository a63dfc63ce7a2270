// Spectral parameter values of the BSDF spec syntax: parsing, file reading, canonical
// text and resampling onto the model's wavelength grid (see twin/bsdf_spec.md).
#include "gonio/twin/detail/bsdf/spectral_param.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"

namespace gonio::twin::bsdf {

void check_pairs(const std::vector<std::pair<double, double>>& pairs, const std::string& field) {
  if (pairs.empty()) throw Error::invalid(field, "a spectrum needs at least one wavelength:value pair");
  if (pairs.size() > kMaxSpectrumPairs)
    throw Error::invalid(field, fmt::format("a spectrum has more than {} pairs", kMaxSpectrumPairs));
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const auto [nm, v] = pairs[i];
    if (!std::isfinite(nm) || !std::isfinite(v))
      throw Error::invalid(field, "spectrum entries must be finite numbers");
    if (!(nm > 0)) throw Error::invalid(field, fmt::format("wavelength {:g} nm is not positive", nm));
    if (i > 0 && !(nm > pairs[i - 1].first))
      throw Error::invalid(field, fmt::format("wavelength {:g} nm does not increase on {:g} nm", nm,
                                              pairs[i - 1].first));
  }
}

RawValue parse_value_text(std::string_view text, const std::string& field) {
  text = text::trim(text);
  if (text.empty()) throw Error::invalid(field, "missing value");
  if (text.front() == '@') {
    const auto path = text::trim(text.substr(1));
    if (path.empty()) throw Error::invalid(field, "'@' needs a file name");
    RawValue v;
    v.kind = RawValue::Kind::file;
    v.path = std::string(path);
    return v;
  }
  if (text.find(':') == std::string_view::npos) return RawValue::of(text::parse_double(field, text));
  RawValue v;
  v.kind = RawValue::Kind::pairs;
  for (const auto item : text::split(text, ',')) {
    const auto parts = text::split(item, ':');
    if (parts.size() != 2)
      throw Error::invalid(field, fmt::format("'{}' is not a wavelength:value pair", text::trim(item)));
    v.pairs.emplace_back(text::parse_double(field, parts[0]), text::parse_double(field, parts[1]));
    if (v.pairs.size() > kMaxSpectrumPairs) break;  // check_pairs reports it
  }
  check_pairs(v.pairs, field);
  return v;
}

std::vector<std::pair<double, double>> read_spectrum_file(const std::string& path,
                                                          const std::string& field) {
  namespace fs = std::filesystem;
  std::error_code ec;
  // Only regular files: a device or a FIFO could be endless.
  if (!fs::is_regular_file(path, ec))
    throw Error(Errc::not_found, fmt::format("{}: spectrum file '{}' does not exist or is not a regular file", field, path), field);
  const auto size = fs::file_size(path, ec);
  if (ec || size > kMaxSpectrumFileBytes)
    throw Error(Errc::parse_error,
                fmt::format("{}: spectrum file '{}' is larger than {} bytes", field, path, kMaxSpectrumFileBytes),
                field);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(Errc::not_found, fmt::format("{}: cannot open spectrum file '{}'", field, path), field);
  const std::string content((std::istreambuf_iterator<char>(in)), {});

  std::vector<std::pair<double, double>> pairs;
  std::size_t line_no = 0;
  for (auto line : text::split(content, '\n')) {
    ++line_no;
    line = text::trim(line);
    if (line.empty() || line.front() == '#') continue;
    std::vector<std::string_view> cols;
    std::size_t i = 0;
    while (i < line.size()) {
      const auto sep = line.find_first_of(",; \t", i);
      const auto end = sep == std::string_view::npos ? line.size() : sep;
      if (end > i) cols.push_back(line.substr(i, end - i));
      i = end + 1;
    }
    const auto where = fmt::format("{}: {}:{}", field, path, line_no);
    if (cols.size() != 2)
      throw Error(Errc::parse_error, fmt::format("{}: expected two columns (nm, value), found {}", where, cols.size()), field);
    try {
      pairs.emplace_back(text::parse_double(field, cols[0]), text::parse_double(field, cols[1]));
      if (pairs.size() > kMaxSpectrumPairs) check_pairs(pairs, field);
    } catch (const Error& e) {
      throw Error(Errc::parse_error, fmt::format("{}: {}", where, e.what()), field);
    }
  }
  if (pairs.empty())
    throw Error(Errc::parse_error, fmt::format("{}: spectrum file '{}' has no data lines", field, path), field);
  try {
    check_pairs(pairs, field);
  } catch (const Error& e) {
    throw Error(Errc::parse_error, fmt::format("{} (in '{}')", e.what(), path), field);
  }
  return pairs;
}

std::string format_value(const RawValue& v) {
  switch (v.kind) {
    case RawValue::Kind::number:
      return text::format_number(v.number);
    case RawValue::Kind::file:
      return "@" + v.path;
    case RawValue::Kind::pairs:
      break;
  }
  std::string out;
  for (const auto& [nm, value] : v.pairs) {
    if (!out.empty()) out += ',';
    out += text::format_number(nm) + ":" + text::format_number(value);
  }
  return out;
}

std::vector<double> resample(const RawValue& v, const WavelengthGrid& grid, const std::string& field,
                             std::vector<std::pair<double, double>>& pairs) {
  switch (v.kind) {
    case RawValue::Kind::number:
      pairs = {{0.0, v.number}};
      return std::vector<double>(grid.size(), v.number);
    case RawValue::Kind::pairs:
      pairs = v.pairs;
      break;
    case RawValue::Kind::file:
      pairs = read_spectrum_file(v.path, field);
      break;
  }
  std::vector<double> x, y;
  x.reserve(pairs.size());
  y.reserve(pairs.size());
  for (const auto& [nm, value] : pairs) {
    x.push_back(nm);
    y.push_back(value);
  }
  return interpolate_linear(x, y, grid.values());
}

}  // namespace gonio::twin::bsdf
