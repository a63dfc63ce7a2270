// scan.material: a stored fit's material written for a renderer (twin/material.md) — Mitsuba 3
// scene XML, or glTF 2.0 fitted to it by CIEDE2000 with its error — returned as the file's
// text for the client to save. MERL tables (11.7 MB of binary) are gonio-twin's alone.
#include <filesystem>
#include <fstream>
#include <iterator>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/twin/material.hpp"
#include "methods/inverse.hpp"
#include "methods/params.hpp"
#include "methods/registrar.hpp"

namespace gonio::daemon {

using json_util::ObjectReader;
using nlohmann::json;

namespace {

constexpr std::size_t kFitsSearched = 1000;

StoredFit find_fit(const Store& store, std::int64_t scan, std::optional<std::int64_t> id) {
  for (const auto& f : store.fits(scan, kFitsSearched)) {
    if (f.kind != FitKind::fit) continue;
    if (!id || f.id == *id) return f;
  }
  if (id) throw Error::not_found("fit", fmt::format("scan {} has no fit {}", scan, *id));
  throw Error::wrong_state("fit", fmt::format("scan {} has no fit yet: run scan.fit first", scan));
}

json summary(const twin::material::DeltaESummary& s) {
  return {{"mean", s.mean}, {"p95", s.p95}, {"max", s.max}, {"samples", s.samples}};
}

rpc::Result scan_material(Services& s, rpc::Call& c) {
  ObjectReader r(c.params, "");
  const auto scan = methods::read_id(r, "scan");
  std::optional<std::int64_t> fit;
  if (r.raw("fit") != nullptr) fit = methods::read_id(r, "fit");
  const auto format_text = r.required<std::string>("format");
  r.finish();
  const auto format = from_text<twin::material::Format>(format_text);
  if (!format || *format == twin::material::Format::merl)
    throw Error::invalid("format", fmt::format("'{}': expected mitsuba or gltf (MERL tables are "
                                               "written by gonio-twin material)", format_text));
  methods::require_scan(s.store, scan);
  const auto stored = find_fit(s.store, scan, fit);
  const std::string spec = stored.result.value("spec", std::string());
  if (spec.empty()) throw Error::wrong_state("fit", fmt::format("fit {} holds no fitted spec", stored.id));

  const auto dir = std::filesystem::temp_directory_path() /
                   fmt::format("gonio-material-{}-{}", scan, stored.id);
  std::filesystem::create_directories(dir);
  const auto path = (dir / (*format == twin::material::Format::gltf ? "material.gltf" : "material.xml")).string();
  twin::material::GltfFitOptions options;
  options.render_check = false;  // the geometries' ΔE00 only: a render would hold the worker for minutes
  const auto report = methods::with_field("fit", [&] {
    return twin::material::export_material(spec, *format, path, WavelengthGrid::visible(), options);
  });
  std::ifstream in(path, std::ios::binary);
  std::string content((std::istreambuf_iterator<char>(in)), {});
  std::filesystem::remove_all(dir);

  json out{{"scan", scan},
           {"fit", stored.id},
           {"format", to_text(*format)},
           {"spec", report.spec},
           {"filename", fmt::format("scan{}-fit{}.{}", scan, stored.id,
                                    *format == twin::material::Format::gltf ? "gltf" : "xml")},
           {"media_type", *format == twin::material::Format::gltf ? "model/gltf+json" : "application/xml"},
           {"content", std::move(content)},
           {"notes", report.notes}};
  if (report.gltf) {
    out["gltf"] = {{"spec", report.gltf->spec}, {"delta_e_geometries", summary(report.gltf->geometries)}};
  }
  spdlog::info("scan {} fit {} written as {} for {}", scan, stored.id, to_text(*format), methods::actor(c));
  return out;
}

}  // namespace

void register_material(MethodRegistrar& reg, Services& s) {
  reg.add("scan.material", [&s](rpc::Call& c) { return scan_material(s, c); });
}

}  // namespace gonio::daemon
