// export_material: one spec to one file in one format, with what the format approximates.
#include <fstream>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf_io.hpp"
#include "gonio/twin/material.hpp"
#include "material/lobes.hpp"

namespace gonio::twin::material {
namespace {

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw Error(Errc::io_error, fmt::format("cannot open '{}' for writing", path), "output");
  out << text;
  out.close();
  if (!out) throw Error(Errc::io_error, fmt::format("cannot write '{}'", path), "output");
}

// What Mitsuba's plugin does differently from the twin's lobe (mitsuba.cpp).
std::vector<std::string> mitsuba_notes(std::string_view spec, const WavelengthGrid& grid) {
  std::vector<std::string> notes;
  for (const auto& l : canonical_lobes(spec, grid)) {
    if (l.name == "conductor" || l.name == "coat" || l.name == "dielectric" || l.name == "plastic")
      notes.push_back(fmt::format("{}: Mitsuba masks with the separable Smith G1·G1, the twin with the "
                                  "height-correlated G2 (equal at normal incidence, Mitsuba darker "
                                  "toward grazing: twin/material.md)", l.name));
    if (l.name == "beckmann")
      notes.push_back("beckmann: Mitsuba's Smith G1 is Walter's rational approximation of the "
                      "exact Λ the twin evaluates, and separable (twin/material.md)");
    if (l.name == "plastic")
      notes.push_back("plastic: roughplastic tabulates the interface's transmittance on 64 "
                      "nodes where the twin integrates it on 33");
  }
  return notes;
}

}  // namespace

ExportReport export_material(std::string_view spec, Format format, const std::string& path,
                             const WavelengthGrid& grid, const GltfFitOptions& options) {
  ExportReport r;
  r.format = format;
  r.spec = make_bsdf(spec, grid)->spec();
  switch (format) {
    case Format::mitsuba: {
      const auto xml = mitsuba_scene(spec, grid);
      r.notes = mitsuba_notes(spec, grid);
      write_text(path, xml);
      break;
    }
    case Format::gltf: {
      refuse_transmission(spec, grid, "glTF 2.0");
      const auto lobes = canonical_lobes(spec, grid);
      GltfMaterial m;
      if (lobes.size() == 1 && lobes[0].name == "gltf") {
        m = gltf_from_spec(spec, grid);
        r.notes.push_back("a gltf lobe: written as it is, colours as linear sRGB of its spectra");
      } else {
        const auto target = make_bsdf(spec, grid);
        r.gltf = fit_gltf(*target, options);
        m = r.gltf->material;
      }
      write_text(path, gltf_document(m, r.spec));
      break;
    }
    case Format::merl: {
      refuse_transmission(spec, grid, "MERL");
      const WavelengthGrid rgb(std::vector<double>(kRgbWavelengthsNm.begin(), kRgbWavelengthsNm.end()));
      const auto model = make_bsdf(spec, rgb);
      write_merl(path, *model);
      const auto back = load_bsdf_file(path, rgb);
      r.merl = merl_round_trip(*model, *back);
      break;
    }
  }
  return r;
}

}  // namespace gonio::twin::material
