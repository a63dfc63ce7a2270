#include "material/lobes.hpp"

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio::twin::material {

const bsdf::RawValue& Lobe::raw(std::string_view key) const {
  for (const auto& [k, v] : args)
    if (k == key) return v;
  throw Error(Errc::internal, fmt::format("lobe '{}' has no parameter '{}'", name, key));
}

double Lobe::number(std::string_view key) const {
  const auto& v = raw(key);
  if (v.kind != bsdf::RawValue::Kind::number)
    throw Error(Errc::internal, fmt::format("{}.{} is not a single number", name, key));
  return v.number;
}

std::vector<std::pair<double, double>> Lobe::pairs(std::string_view key) const {
  const auto& v = raw(key);
  switch (v.kind) {
    case bsdf::RawValue::Kind::number: return {{0.0, v.number}};
    case bsdf::RawValue::Kind::pairs: return v.pairs;
    case bsdf::RawValue::Kind::file:
      return bsdf::read_spectrum_file(v.path, "bsdf." + name + "." + std::string(key));
  }
  return {};
}

bool Lobe::is_constant(std::string_view key) const {
  const auto p = pairs(key);
  for (const auto& [nm, x] : p)
    if (x != p.front().second) return false;
  return true;
}

std::vector<Lobe> canonical_lobes(std::string_view spec, const WavelengthGrid& grid) {
  const auto model = make_bsdf(spec, grid);
  std::vector<Lobe> out;
  for (auto& l : bsdf::parse_spec_string(model->spec())) {
    if (!l.file.empty()) {
      out.push_back({"@file", {}});
      continue;
    }
    out.push_back({std::move(l.name), std::move(l.args)});
  }
  return out;
}

void refuse(std::string_view lobe, std::string_view format, std::string_view why) {
  throw Error(Errc::unsupported,
              fmt::format("lobe '{}' cannot be written as {}: {}", lobe, format, why),
              "bsdf." + std::string(lobe));
}

}  // namespace gonio::twin::material
