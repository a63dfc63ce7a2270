// CIE colour-matching functions and illuminants, read from colord-data's CGATS files.
//
// Nothing is tabulated here: the 2° and 10° observers come from cmf/CIE1931-2deg-XYZ.cmf
// and cmf/CIE1964-10deg-XYZ.cmf (three sets x̄, ȳ, z̄), illuminants from
// illuminant/CIE-<name>.sp (one set). Loaded tables are cached per directory, because the
// daemon converts a spectrum per measured point.
#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "color/cgats.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/twin/color.hpp"

#ifndef GONIO_COLORD_DIR
#define GONIO_COLORD_DIR "/usr/share/colord"
#endif

namespace gonio::twin {
namespace {

// Linear interpolation in a sorted table; zero outside [front, back].
double table_at(const std::vector<double>& x, const std::vector<double>& y, double t) {
  if (x.empty() || t < x.front() || t > x.back()) return 0;
  const auto it = std::upper_bound(x.begin(), x.end(), t);
  if (it == x.end()) return y.back();
  const auto i = static_cast<std::size_t>(it - x.begin());
  const double w = (t - x[i - 1]) / (x[i] - x[i - 1]);
  return y[i - 1] + w * (y[i] - y[i - 1]);
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (auto& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string upper(std::string_view s) {
  std::string out(s);
  for (auto& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

const char* cmf_file(ObserverKind kind) {
  return kind == ObserverKind::cie1931_2deg ? "CIE1931-2deg-XYZ.cmf" : "CIE1964-10deg-XYZ.cmf";
}

}  // namespace

std::string colord_dir() {
  const char* env = std::getenv("GONIO_COLORD_DIR");
  return (env != nullptr && *env != '\0') ? std::string(env) : std::string(GONIO_COLORD_DIR);
}

ObserverKind parse_observer(std::string_view text, std::string_view field) {
  const auto t = lower(text);
  if (t == "2" || t == "2deg" || t == "cie1931") return ObserverKind::cie1931_2deg;
  if (t == "10" || t == "10deg" || t == "cie1964") return ObserverKind::cie1964_10deg;
  throw Error::invalid(std::string(field),
                       fmt::format("unknown observer '{}', expected 2 (CIE 1931) or 10 (CIE 1964)",
                                   text));
}

std::string_view observer_name(ObserverKind kind) noexcept {
  return kind == ObserverKind::cie1931_2deg ? "CIE 1931 2°" : "CIE 1964 10°";
}

// ---- Observer ----------------------------------------------------------------------

Observer Observer::load(ObserverKind kind, const std::string& dir) {
  const auto t = cgats::read((std::filesystem::path(dir) / "cmf" / cmf_file(kind)).string());
  Observer o;
  o.kind_ = kind;
  o.nm_ = t.wavelengths();
  if (t.sets.size() != 3)
    throw Error(Errc::parse_error,
                fmt::format("{}:{}: expected 3 data sets (x̄, ȳ, z̄), found {}", t.path,
                            t.data_line, t.sets.size()));
  o.x_ = t.sets[0];
  o.y_ = t.sets[1];
  o.z_ = t.sets[2];
  return o;
}

const Observer& Observer::get(ObserverKind kind) {
  static std::mutex mutex;
  static std::map<std::pair<std::string, int>, std::unique_ptr<const Observer>> cache;
  const auto key = std::make_pair(colord_dir(), static_cast<int>(kind));
  const std::lock_guard lock(mutex);
  auto& slot = cache[key];
  if (!slot) {
    try {
      slot = std::make_unique<const Observer>(load(kind, key.first));
    } catch (...) {
      cache.erase(key);
      throw;
    }
  }
  return *slot;
}

Xyz Observer::at(double nm) const {
  return {table_at(nm_, x_, nm), table_at(nm_, y_, nm), table_at(nm_, z_, nm)};
}

// ---- Illuminant --------------------------------------------------------------------

Illuminant Illuminant::load(std::string_view name, const std::string& dir) {
  const auto key = upper(name);
  const bool plain = !key.empty() && key.size() <= 16 &&
                     std::all_of(key.begin(), key.end(), [](char c) {
                       return std::isalnum(static_cast<unsigned char>(c)) != 0;
                     });
  const auto path = std::filesystem::path(dir) / "illuminant" / ("CIE-" + key + ".sp");
  std::error_code ec;
  if (!plain || !std::filesystem::exists(path, ec)) {
    const auto names = available(dir);
    if (names.empty())
      throw Error(Errc::not_found,
                  fmt::format("CIE illuminant '{}' not found: no CIE-*.sp files in '{}' "
                              "(install the Debian package colord-data or set "
                              "GONIO_COLORD_DIR)",
                              name, (std::filesystem::path(dir) / "illuminant").string()),
                  "illuminant");
    throw Error(Errc::not_found,
                fmt::format("CIE illuminant '{}' not found in '{}'; available: {}", name,
                            path.parent_path().string(), fmt::join(names, ", ")),
                "illuminant");
  }
  const auto t = cgats::read(path.string());
  if (t.sets.size() != 1)
    throw Error(Errc::parse_error, fmt::format("{}:{}: expected 1 data set, found {}", t.path,
                                               t.data_line, t.sets.size()));
  Illuminant il;
  il.name_ = key;
  il.nm_ = t.wavelengths();
  il.power_ = t.sets[0];
  return il;
}

const Illuminant& Illuminant::get(std::string_view name) {
  static std::mutex mutex;
  static std::map<std::pair<std::string, std::string>, std::unique_ptr<const Illuminant>> cache;
  const auto key = std::make_pair(colord_dir(), upper(name));
  const std::lock_guard lock(mutex);
  auto& slot = cache[key];
  if (!slot) {
    try {
      slot = std::make_unique<const Illuminant>(load(name, key.first));
    } catch (...) {
      cache.erase(key);
      throw;
    }
  }
  return *slot;
}

std::vector<std::string> Illuminant::available(const std::string& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (std::filesystem::directory_iterator it(std::filesystem::path(dir) / "illuminant", ec), end;
       !ec && it != end; it.increment(ec)) {
    const auto file = it->path().filename().string();
    if (file.size() > 7 && file.starts_with("CIE-") && file.ends_with(".sp"))
      names.push_back(file.substr(4, file.size() - 7));
  }
  std::sort(names.begin(), names.end());
  return names;
}

double Illuminant::at(double nm) const { return table_at(nm_, power_, nm); }

Xyz Illuminant::white_point(const Observer& observer) const {
  return Colorimeter(WavelengthGrid(observer.wavelengths()), *this, observer).white();
}

}  // namespace gonio::twin
