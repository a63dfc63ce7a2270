// Mitsuba 3 scene XML: each lobe of the spec as the Mitsuba plugin of the same model, its
// parameters carried over one for one (Mitsuba 3 documentation, "Plugin reference: BSDFs";
// the table of every parameter written and its source is in the test,
// tests/unit/twin/material/mitsuba_test.cpp):
//
//   lambert     twosided(diffuse: reflectance)
//   mirror      twosided(conductor: material = "none", specular_reflectance)
//   conductor   twosided(roughconductor: distribution = ggx, alpha, eta, k)
//   beckmann    twosided(roughconductor: distribution = beckmann, alpha, eta, k)
//   coat        twosided(roughconductor: ggx, alpha, eta = ior, k = 0) — the Fresnel
//               reflectance of a real index seen from outside is the conductor formula at k = 0
//   dielectric  roughdielectric: ggx, alpha, int_ior = ior, ext_ior = 1
//   plastic     twosided(roughplastic: ggx, alpha, int_ior = ior, diffuse_reflectance,
//               nonlinear = true) — the same layering (twin/bsdf_spec.md)
//   a + b + …   nested blendbsdf: Σ f_k = blend of n·f_k with weights 1/2, 1/3, …, each n·f_k
//               carried by a parameter that scales f linearly (reflectance,
//               specular_reflectance, specular_transmittance), so the sum is exact
//
// Refused, with the reason: oren-nayar and abg (no such Mitsuba 3 plugin), gltf (Mitsuba's
// `principled` is another model), tabulated lobes, a hazy plastic (one roughness only), an
// index-matched dielectric or plastic (Mitsuba requires int_ior ≠ ext_ior), a plastic
// inside a sum (its diffuse term is not linear in its reflectance).
//
// Spectra are Mitsuba spectra "nm:value, …" — not RGB — extended with their end values to
// 360 and 830 nm, since the twin holds a spectrum constant beyond its ends and Mitsuba's
// irregular spectrum is 0 there. What remains different is Mitsuba's masking: its
// microfacet plugins use the separable Smith G1(wi)·G1(wo) where the twin uses the
// height-correlated G2 (twin/material.md gives the size of that difference).
#include <cmath>
#include <map>
#include <memory>
#include <sstream>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"
#include "gonio/twin/material.hpp"
#include "material/lobes.hpp"

namespace gonio::twin::material {
namespace {

using text::format_number;

constexpr std::string_view kFormat = "Mitsuba 3 XML";
constexpr double kLowNm = 360, kHighNm = 830;  // Mitsuba's spectral range


std::string spectrum_text(std::vector<std::pair<double, double>> pairs, double scale) {
  if (pairs.size() == 1 && pairs.front().first == 0) return format_number(pairs.front().second * scale);
  if (pairs.front().first > kLowNm) pairs.insert(pairs.begin(), {kLowNm, pairs.front().second});
  if (pairs.back().first < kHighNm) pairs.emplace_back(kHighNm, pairs.back().second);
  std::string s;
  for (const auto& [nm, v] : pairs) s += (s.empty() ? "" : ", ") + format_number(nm) + ":" + format_number(v * scale);
  return s;
}

struct Writer {
  std::ostringstream out;
  void line(int depth, const std::string& text) { out << std::string(2 * static_cast<std::size_t>(depth), ' ') << text << '\n'; }
  void spectrum(int d, std::string_view name, const Lobe& l, std::string_view key, double scale) {
    line(d, fmt::format(R"(<spectrum name="{}" value="{}"/>)", name, spectrum_text(l.pairs(key), scale)));
  }
  void value(int d, std::string_view type, std::string_view name, const std::string& v) {
    line(d, fmt::format(R"(<{} name="{}" value="{}"/>)", type, name, v));
  }
};

void check_writable(const Lobe& l, bool in_sum) {
  const auto& n = l.name;
  if (n == "oren-nayar" || n == "abg")
    refuse(n, kFormat, "Mitsuba 3 has no plugin for this model");
  if (n == "gltf")
    refuse(n, kFormat, "Mitsuba's `principled` is a different model; export it as glTF");
  if (n == "@file") refuse("path", kFormat, "a tabulated lobe has no Mitsuba plugin; export it as MERL");
  if (n == "plastic" && l.number("haze") > 0)
    refuse(n, kFormat, "roughplastic has one roughness; a hazy interface (haze > 0) needs two");
  if ((n == "plastic" || n == "dielectric") && l.number("ior") == 1)
    refuse(n, kFormat, "Mitsuba requires int_ior to differ from ext_ior (ior = 1)");
  if (n == "plastic" && in_sum)
    refuse(n, kFormat, "roughplastic's diffuse term is not linear in its reflectance, so it "
                       "cannot be scaled into an exact blendbsdf sum");
}

void microfacet(Writer& w, int d, std::string_view dist, double alpha) {
  w.value(d, "string", "distribution", std::string(dist));
  w.value(d, "float", "alpha", format_number(alpha));
  w.value(d, "boolean", "sample_visible", "true");
}

// One lobe scaled by `scale` (1 outside sums).
void write_lobe(Writer& w, int d, const Lobe& l, double scale) {
  const auto& n = l.name;
  const bool two_sided = n != "dielectric";
  if (two_sided) w.line(d++, R"(<bsdf type="twosided">)");
  if (n == "lambert") {
    w.line(d, R"(<bsdf type="diffuse">)");
    w.spectrum(d + 1, "reflectance", l, "albedo", scale);
  } else if (n == "mirror") {
    w.line(d, R"(<bsdf type="conductor">)");
    w.value(d + 1, "string", "material", "none");
    w.spectrum(d + 1, "specular_reflectance", l, "reflectance", scale);
  } else if (n == "conductor" || n == "beckmann" || n == "coat") {
    w.line(d, R"(<bsdf type="roughconductor">)");
    microfacet(w, d + 1, n == "beckmann" ? "beckmann" : "ggx", l.number("alpha"));
    if (n == "coat") {
      w.value(d + 1, "spectrum", "eta", format_number(l.number("ior")));
      w.value(d + 1, "spectrum", "k", "0");
    } else {
      w.spectrum(d + 1, "eta", l, "eta", 1);
      w.spectrum(d + 1, "k", l, "k", 1);
    }
    if (scale != 1) w.value(d + 1, "spectrum", "specular_reflectance", format_number(scale));
  } else if (n == "dielectric") {
    w.line(d, R"(<bsdf type="roughdielectric">)");
    microfacet(w, d + 1, "ggx", l.number("alpha"));
    w.value(d + 1, "float", "int_ior", format_number(l.number("ior")));
    w.value(d + 1, "float", "ext_ior", "1");
    if (scale != 1) {
      w.value(d + 1, "spectrum", "specular_reflectance", format_number(scale));
      w.value(d + 1, "spectrum", "specular_transmittance", format_number(scale));
    }
  } else if (n == "plastic") {
    w.line(d, R"(<bsdf type="roughplastic">)");
    microfacet(w, d + 1, "ggx", l.number("alpha"));
    w.value(d + 1, "float", "int_ior", format_number(l.number("ior")));
    w.value(d + 1, "float", "ext_ior", "1");
    w.spectrum(d + 1, "diffuse_reflectance", l, "albedo", 1);
    w.value(d + 1, "boolean", "nonlinear", "true");
  } else {
    refuse(n, kFormat, "no Mitsuba plugin is known for it");
  }
  w.line(d, "</bsdf>");
  if (two_sided) w.line(--d, "</bsdf>");
}

// M_k = blendbsdf(weight 1/k, M_{k−1}, n·f_k), so that M_n = Σ f_k.
void write_sum(Writer& w, int d, const std::vector<Lobe>& lobes, std::size_t k) {
  const double n = static_cast<double>(lobes.size());
  if (k == 1) return write_lobe(w, d, lobes[0], n);
  w.line(d, R"(<bsdf type="blendbsdf">)");
  w.value(d + 1, "float", "weight", format_number(1.0 / static_cast<double>(k)));
  write_sum(w, d + 1, lobes, k - 1);
  write_lobe(w, d + 1, lobes[k - 1], n);
  w.line(d, "</bsdf>");
}

}  // namespace

std::string mitsuba_scene(std::string_view spec, const WavelengthGrid& grid) {
  const auto lobes = canonical_lobes(spec, grid);
  for (const auto& l : lobes) check_writable(l, lobes.size() > 1);
  Writer inner;
  if (lobes.size() == 1)
    write_lobe(inner, 1, lobes[0], 1);
  else
    write_sum(inner, 1, lobes, lobes.size());
  std::string body = inner.out.str();
  Writer scene;
  scene.line(0, R"(<?xml version="1.0" encoding="utf-8"?>)");
  std::string canonical = make_bsdf(spec, grid)->spec();
  for (auto p = canonical.find("--"); p != std::string::npos; p = canonical.find("--", p))
    canonical.replace(p, 2, "- ");  // "--" may not appear in an XML comment
  scene.line(0, "<!-- gonio material: " + canonical + " -->");
  scene.line(0, "<!-- spectra as written: render with a spectral variant (e.g. scalar_spectral) -->");
  scene.line(0, R"(<scene version="3.0.0">)");
  // The first <bsdf of the body gets the id.
  const auto at = body.find("<bsdf ");
  body.insert(at + 5, R"( id="material")");
  scene.out << body;
  scene.line(1, R"(<shape type="sphere">)");
  scene.line(2, R"(<ref id="material"/>)");
  scene.line(1, "</shape>");
  scene.line(1, R"(<emitter type="constant">)");
  scene.line(2, R"(<spectrum name="radiance" value="1"/>)");
  scene.line(1, "</emitter>");
  scene.line(1, R"(<sensor type="perspective">)");
  scene.line(2, R"(<float name="fov" value="30"/>)");
  scene.line(2, R"(<transform name="to_world">)");
  scene.line(3, R"(<lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/>)");
  scene.line(2, "</transform>");
  scene.line(2, R"(<film type="hdrfilm">)");
  scene.line(3, R"(<integer name="width" value="256"/>)");
  scene.line(3, R"(<integer name="height" value="256"/>)");
  scene.line(2, "</film>");
  scene.line(1, "</sensor>");
  scene.line(0, "</scene>");
  return scene.out.str();
}

}  // namespace gonio::twin::material
