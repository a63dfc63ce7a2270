// The canonical lobes of a spec, for the writers: the model is built first (so the spec is
// validated and every parameter is written out), then its canonical spec is parsed again.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/detail/bsdf/spec.hpp"

namespace gonio::twin::material {

struct Lobe {
  std::string name;  // model name, or "@file" for a tabulated lobe
  std::vector<std::pair<std::string, bsdf::RawValue>> args;

  // A parameter's value: a number, or (nm, value) pairs (a file's contents read in).
  const bsdf::RawValue& raw(std::string_view key) const;
  double number(std::string_view key) const;
  std::vector<std::pair<double, double>> pairs(std::string_view key) const;
};

// Builds `spec` on `grid` and returns its canonical lobes.
std::vector<Lobe> canonical_lobes(std::string_view spec, const WavelengthGrid& grid);

// Error(unsupported) naming the lobe (field "bsdf.<lobe>") and the format.
[[noreturn]] void refuse(std::string_view lobe, std::string_view format, std::string_view why);

// For the formats that hold reflection only (glTF as written, MERL): refuses a spec with a
// lobe that transmits — `dielectric`, or a table with transmitted light — rather than drop
// that light silently.
void refuse_transmission(std::string_view spec, const WavelengthGrid& grid, std::string_view format);

}  // namespace gonio::twin::material
