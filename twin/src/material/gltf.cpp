// glTF 2.0 out: the material's parameters as the twin's `gltf` spec and back, RGB ↔
// spectrum, and the .gltf document — one UV sphere in an embedded buffer with the material
// (glTF 2.0 §3.9 "Materials", §3.6 "Buffers" with a data: URI; KHR_materials_ior,
// KHR_materials_specular, KHR_materials_clearcoat).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"
#include "gonio/twin/color.hpp"
#include "gonio/twin/material.hpp"
#include "material/lobes.hpp"

namespace gonio::twin::material {
namespace {

using text::format_number;

// The ramps of rgb_spectrum: blue up to 470 nm, green 530–560 nm, red from 610 nm.
constexpr double kBlueNm = 470, kGreenLoNm = 530, kGreenHiNm = 560, kRedNm = 610;

std::string base64(const std::vector<std::uint8_t>& bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::uint32_t a = bytes[i], b = i + 1 < bytes.size() ? bytes[i + 1] : 0,
                        c = i + 2 < bytes.size() ? bytes[i + 2] : 0;
    const std::uint32_t v = a << 16 | b << 8 | c;
    out += kAlphabet[v >> 18 & 63];
    out += kAlphabet[v >> 12 & 63];
    out += i + 1 < bytes.size() ? kAlphabet[v >> 6 & 63] : '=';
    out += i + 2 < bytes.size() ? kAlphabet[v & 63] : '=';
  }
  return out;
}

void put_f32(std::vector<std::uint8_t>& b, float v) {
  std::uint32_t u;
  std::memcpy(&u, &v, 4);
  for (int k = 0; k < 4; ++k) b.push_back(static_cast<std::uint8_t>(u >> (8 * k)));
}

void put_u32(std::vector<std::uint8_t>& b, std::uint32_t u) {
  for (int k = 0; k < 4; ++k) b.push_back(static_cast<std::uint8_t>(u >> (8 * k)));
}

nlohmann::json rgb_json(const std::array<double, 3>& c) { return {c[0], c[1], c[2]}; }

}  // namespace

std::string rgb_spectrum(const std::array<double, 3>& rgb) {
  const auto& [r, g, b] = rgb;
  if (r == g && g == b) return format_number(r);
  return fmt::format("{}:{},{}:{},{}:{},{}:{}", format_number(kBlueNm), format_number(b),
                     format_number(kGreenLoNm), format_number(g), format_number(kGreenHiNm),
                     format_number(g), format_number(kRedNm), format_number(r));
}

std::array<double, 3> spectrum_rgb(std::span<const double> values, const WavelengthGrid& grid) {
  // White-aligned XYZ as the renderer computes it (render/color_bsdf.cpp): D65, CIE 1931 2°,
  // X and Z scaled so that a flat spectrum lands on the sRGB white.
  const Colorimeter cm(grid, Illuminant::get("D65"), Observer::get(ObserverKind::cie1931_2deg));
  const double wx = 0.3127 / 0.3290, wz = (1 - 0.3127 - 0.3290) / 0.3290;
  Xyz xyz;
  for (std::size_t c = 0; c < values.size(); ++c) {
    xyz.x += cm.weights()[c].x / cm.white().x * wx * values[c];
    xyz.y += cm.weights()[c].y / cm.white().y * values[c];
    xyz.z += cm.weights()[c].z / cm.white().z * wz * values[c];
  }
  const Rgb rgb = xyz_to_linear_srgb(xyz);
  return {rgb.r, rgb.g, rgb.b};
}

std::string gltf_spec(const GltfMaterial& m) {
  return fmt::format("gltf:base_color={},metallic={},roughness={},ior={},specular={},"
                     "specular_color={},clearcoat={},clearcoat_roughness={}",
                     rgb_spectrum(m.base_color), format_number(m.metallic),
                     format_number(m.roughness), format_number(m.ior), format_number(m.specular),
                     rgb_spectrum(m.specular_color), format_number(m.clearcoat),
                     format_number(m.clearcoat_roughness));
}

GltfMaterial gltf_from_spec(std::string_view spec, const WavelengthGrid& grid) {
  const auto lobes = canonical_lobes(spec, grid);
  if (lobes.size() != 1 || lobes[0].name != "gltf")
    throw Error::invalid("bsdf", "not a single `gltf` lobe");
  const auto& l = lobes[0];
  const auto color = [&](std::string_view key) {
    std::vector<std::pair<double, double>> points;
    const auto f = bsdf::resample(l.raw(key), grid, "bsdf.gltf." + std::string(key), points);
    auto rgb = spectrum_rgb(f, grid);
    for (auto& v : rgb) v = std::clamp(v, 0.0, key == "base_color" ? 1.0 : 25.0);
    return rgb;
  };
  GltfMaterial m;
  m.base_color = color("base_color");
  m.specular_color = color("specular_color");
  m.metallic = l.number("metallic");
  m.roughness = l.number("roughness");
  m.ior = l.number("ior");
  m.specular = l.number("specular");
  m.clearcoat = l.number("clearcoat");
  m.clearcoat_roughness = l.number("clearcoat_roughness");
  return m;
}

std::string gltf_document(const GltfMaterial& m, std::string_view name, int rings) {
  if (rings < 4 || rings > 512) throw Error::out_of_range("rings", rings, 4, 512);
  const int segs = 2 * rings;
  // Vertices on (rings + 1) × (segs + 1) nodes (a seam column repeated), y up as glTF's.
  std::vector<std::uint8_t> pos, nrm, idx;
  float lo[3] = {1, 1, 1}, hi[3] = {-1, -1, -1};
  for (int i = 0; i <= rings; ++i) {
    const double th = kPi * i / rings;
    for (int j = 0; j <= segs; ++j) {
      const double ph = 2 * kPi * j / segs;
      const float v[3] = {static_cast<float>(std::sin(th) * std::cos(ph)), static_cast<float>(std::cos(th)),
                          static_cast<float>(-std::sin(th) * std::sin(ph))};
      for (int k = 0; k < 3; ++k) {
        put_f32(pos, v[k]);
        put_f32(nrm, v[k]);
        lo[k] = std::min(lo[k], v[k]);
        hi[k] = std::max(hi[k], v[k]);
      }
    }
  }
  std::size_t triangles = 0;
  const auto at = [segs](int i, int j) { return static_cast<std::uint32_t>(i * (segs + 1) + j); };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segs; ++j) {
      // Counter-clockwise seen from outside (glTF front faces).
      const std::uint32_t a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
      if (i > 0) { for (auto u : {a, b, d}) put_u32(idx, u); ++triangles; }
      if (i < rings - 1) { for (auto u : {d, b, c}) put_u32(idx, u); ++triangles; }
    }
  const std::size_t vertices = static_cast<std::size_t>((rings + 1) * (segs + 1));
  std::vector<std::uint8_t> buffer = pos;
  buffer.insert(buffer.end(), nrm.begin(), nrm.end());
  buffer.insert(buffer.end(), idx.begin(), idx.end());

  nlohmann::json material = {
      {"name", std::string(name)},
      {"pbrMetallicRoughness",
       {{"baseColorFactor", {m.base_color[0], m.base_color[1], m.base_color[2], 1.0}},
        {"metallicFactor", m.metallic},
        {"roughnessFactor", m.roughness}}},
      {"extensions",
       {{"KHR_materials_ior", {{"ior", m.ior}}},
        {"KHR_materials_specular",
         {{"specularFactor", m.specular}, {"specularColorFactor", rgb_json(m.specular_color)}}}}}};
  std::vector<std::string> used{"KHR_materials_ior", "KHR_materials_specular"};
  if (m.clearcoat > 0) {
    material["extensions"]["KHR_materials_clearcoat"] = {
        {"clearcoatFactor", m.clearcoat}, {"clearcoatRoughnessFactor", m.clearcoat_roughness}};
    used.emplace_back("KHR_materials_clearcoat");
  }
  using nlohmann::json;
  const auto view = [](std::size_t offset, std::size_t length, int target) {
    return json{{"buffer", 0}, {"byteOffset", offset}, {"byteLength", length}, {"target", target}};
  };
  const auto accessor = [](int view_index, int component, std::size_t count, const char* type) {
    return json{{"bufferView", view_index}, {"componentType", component}, {"count", count}, {"type", type}};
  };
  json positions = accessor(0, 5126, vertices, "VEC3");
  positions["min"] = {lo[0], lo[1], lo[2]};
  positions["max"] = {hi[0], hi[1], hi[2]};
  json primitive{{"attributes", json{{"POSITION", 0}, {"NORMAL", 1}}}, {"indices", 2}, {"material", 0}, {"mode", 4}};
  json doc;
  doc["asset"] = json{{"version", "2.0"}, {"generator", "gonio-twin material"}};
  doc["extensionsUsed"] = used;
  doc["scene"] = 0;
  doc["scenes"] = json::array({json{{"nodes", json::array({0})}}});
  doc["nodes"] = json::array({json{{"mesh", 0}, {"name", "sphere"}}});
  doc["meshes"] = json::array({json{{"name", "sphere"}, {"primitives", json::array({primitive})}}});
  doc["materials"] = json::array({material});
  doc["buffers"] = json::array({json{{"byteLength", buffer.size()},
                                     {"uri", "data:application/octet-stream;base64," + base64(buffer)}}});
  doc["bufferViews"] = json::array({view(0, pos.size(), 34962), view(pos.size(), nrm.size(), 34962),
                                    view(pos.size() + nrm.size(), idx.size(), 34963)});
  doc["accessors"] = json::array({positions, accessor(1, 5126, vertices, "VEC3"),
                                  accessor(2, 5125, 3 * triangles, "SCALAR")});
  return doc.dump(1) + "\n";
}

}  // namespace gonio::twin::material
