// make_bsdf: builds a model from a parsed spec. Looks each lobe up in the registry of
// models, rejects unknown and repeated keys, range-checks every value (every point of a
// spectrum), resamples spectra onto the grid and writes the canonical spec; '@file'
// lobes go to the tabulated family's load_bsdf_file.
#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/twin/detail/bsdf/model.hpp"
#include "gonio/twin/detail/bsdf/spec.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio::twin {
namespace bsdf {
namespace {

std::string allowed_keys(const ModelInfo& m) {
  std::string out;
  for (const auto& p : m.params) out += (out.empty() ? "" : ", ") + std::string(p.key);
  return out;
}

std::string known_models() {
  std::string out;
  for (const auto* m : models()) out += (out.empty() ? "" : ", ") + std::string(m->name);
  return out + ", @file";
}

void check_range(const ParamInfo& p, double v, const std::string& field, double nm) {
  const bool ok = (p.lo_open ? v > p.lo : v >= p.lo) && v <= p.hi;
  if (ok) return;
  const auto at = nm > 0 ? fmt::format(" at {:g} nm", nm) : std::string();
  throw Error(Errc::out_of_range,
              fmt::format("{} = {:g}{}{} is outside the allowed range {}{:g}, {:g}]{}", field, v,
                          p.unit, at, p.lo_open ? "(" : "[", p.lo, p.hi, p.unit),
              field);
}

BsdfPtr build_lobe(const LobeSpec& lobe, const WavelengthGrid& grid) {
  if (!lobe.file.empty()) {
    try {
      return load_bsdf_file(lobe.file, grid);
    } catch (const Error& e) {
      throw json_util::prefixed(e, "bsdf");  // "path" -> "bsdf.path"
    }
  }
  const ModelInfo* model = find_model(lobe.name);
  if (model == nullptr)
    throw Error::invalid("bsdf", fmt::format("unknown lobe '{}' (known: {})", lobe.name, known_models()));
  const auto field_of = [&](std::string_view key) {
    return join_field(join_field("bsdf", model->name), key);
  };
  for (std::size_t i = 0; i < lobe.args.size(); ++i) {
    const auto& key = lobe.args[i].first;
    const bool known = std::any_of(model->params.begin(), model->params.end(),
                                   [&](const ParamInfo& p) { return p.key == key; });
    if (!known)
      throw Error::invalid(field_of(key), fmt::format("unknown key '{}' for lobe '{}' (allowed: {})",
                                                      key, model->name, allowed_keys(*model)));
    for (std::size_t j = 0; j < i; ++j)
      if (lobe.args[j].first == key) throw Error::invalid(field_of(key), "is given twice");
  }

  std::vector<Params::Entry> entries;
  std::string spec(model->name);
  for (std::size_t i = 0; i < model->params.size(); ++i) {
    const auto& p = model->params[i];
    const auto field = field_of(p.key);
    const auto it = std::find_if(lobe.args.begin(), lobe.args.end(),
                                 [&](const auto& a) { return a.first == p.key; });
    const RawValue value = it == lobe.args.end() ? RawValue::of(p.fallback) : it->second;
    if (!p.spectral && value.kind != RawValue::Kind::number)
      throw Error::invalid(field, "must be a single number: it cannot vary with wavelength "
                                  "(all channels share one geometry)");
    std::vector<std::pair<double, double>> points;
    auto values = resample(value, grid, field, points);
    for (const auto& [nm, v] : points) check_range(p, v, field, nm);
    entries.push_back({std::string(p.key), std::move(values)});
    spec += (i == 0 ? ":" : ",") + std::string(p.key) + "=" + format_value(value);
  }
  return model->build(Params(std::move(entries), std::move(spec)), grid);
}

BsdfPtr build(const std::vector<LobeSpec>& lobes, const WavelengthGrid& grid) {
  if (grid.empty()) throw Error::invalid("wavelengths", "a BSDF needs at least one wavelength");
  std::vector<BsdfPtr> built;
  built.reserve(lobes.size());
  for (const auto& l : lobes) built.push_back(build_lobe(l, grid));
  if (built.size() == 1) return built.front();
  return make_sum(std::move(built), grid);
}

}  // namespace

const std::vector<double>& Params::spectrum(std::string_view key) const {
  for (const auto& e : entries_)
    if (e.key == key) return e.values;
  throw Error(Errc::internal, fmt::format("model parameter '{}' is not in its table", key));
}

double mean(std::span<const double> v) noexcept {
  double s = 0;
  for (const double x : v) s += x;
  return v.empty() ? 0.0 : s / static_cast<double>(v.size());
}

double albedo_hint(const Bsdf& b, const Vec3& wo) {
  if (const auto* lobe = dynamic_cast<const Lobe*>(&b)) return lobe->albedo_hint(wo);
  constexpr int kN = 8;
  std::array<double, WavelengthGrid::kMaxChannels> f{};
  const std::span<double> out(f.data(), b.channels());
  double sum = 0;
  for (int i = 0; i < kN; ++i) {
    for (int j = 0; j < kN; ++j) {
      const Vec2 u{(i + 0.5) / kN, (j + 0.5) / kN};
      const auto s = b.sample_wi(wo, (i * kN + j + 0.5) / (kN * kN), u);
      if (!s || !(s->pdf > 0)) continue;
      b.eval(s->wi, wo, out);
      sum += mean(out) * abs_cos_theta(s->wi) / s->pdf;
    }
  }
  const double hint = sum / (kN * kN);
  return std::isfinite(hint) && hint > 0 ? hint : 1e-3;  // never starve a lobe
}

namespace {
// Filled during static initialisation, so built on first use rather than as a global whose
// construction might come after a registrar's. A deque keeps the infos where they are.
struct Registry {
  std::deque<ModelInfo> infos;
  std::vector<const ModelInfo*> by_name;
};
Registry& registry() {
  static Registry r;
  return r;
}
}  // namespace

Registrar::Registrar(ModelInfo info) {
  // Name order does not depend on the order the linker placed the models' files in.
  auto& r = registry();
  const auto* m = &r.infos.emplace_back(std::move(info));
  r.by_name.insert(std::upper_bound(r.by_name.begin(), r.by_name.end(), m,
                                    [](const ModelInfo* a, const ModelInfo* b) { return a->name < b->name; }),
                   m);
}

std::span<const ModelInfo* const> models() { return registry().by_name; }

const ModelInfo* find_model(std::string_view name) {
  for (const auto* m : models())
    if (m->name == name) return m;
  return nullptr;
}

}  // namespace bsdf

BsdfPtr make_bsdf(std::string_view spec, const WavelengthGrid& grid) {
  return bsdf::build(bsdf::parse_spec_string(spec), grid);
}

BsdfPtr make_bsdf(const nlohmann::json& spec, const WavelengthGrid& grid) {
  return bsdf::build(bsdf::parse_spec_json(spec), grid);
}

}  // namespace gonio::twin
