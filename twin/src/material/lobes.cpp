#include "material/lobes.hpp"

#include <cmath>

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

namespace {

// Whether `b` sends light through the surface: from a few receivers, a stratified set of
// sampled source directions on the other side with f > 0, or a delta lobe there.
bool transmits(const Bsdf& b) {
  std::vector<double> f(b.channels());
  std::vector<DeltaLobe> deltas;
  constexpr int kStrata = 16;
  for (const double t : {0.0, 30.0, 60.0, 80.0}) {
    const Vec3 wo{std::sin(t * kDegToRad), 0, std::cos(t * kDegToRad)};
    deltas.clear();
    b.delta_lobes(wo, deltas);
    for (const auto& d : deltas)
      for (const double w : d.weight)
        if (d.wi.z < 0 && w > 0) return true;
    for (int i = 0; i < kStrata; ++i)
      for (int j = 0; j < kStrata; ++j) {
        const double u_lobe = (i + 0.5) / kStrata;
        const auto s = b.sample_wi(wo, u_lobe, {(j + 0.5) / kStrata, (i * kStrata + j + 0.5) / (kStrata * kStrata)});
        if (!s || s->wi.z >= 0) continue;
        b.eval(s->wi, wo, f);
        for (const double v : f)
          if (v > 0) return true;
      }
  }
  return false;
}

}  // namespace

void refuse_transmission(std::string_view spec, const WavelengthGrid& grid, std::string_view format) {
  const auto lobes = canonical_lobes(spec, grid);
  for (const auto& l : lobes)
    if (l.name == "dielectric")
      refuse(l.name, format, "it transmits, and the file holds reflection only (its light would be dropped)");
  for (const auto& l : lobes)
    if (l.name == "@file" && transmits(*make_bsdf(spec, grid)))
      refuse("path", format, "the table transmits, and the file holds reflection only (its light would be dropped)");
}

void refuse(std::string_view lobe, std::string_view format, std::string_view why) {
  throw Error(Errc::unsupported,
              fmt::format("lobe '{}' cannot be written as {}: {}", lobe, format, why),
              "bsdf." + std::string(lobe));
}

}  // namespace gonio::twin::material
