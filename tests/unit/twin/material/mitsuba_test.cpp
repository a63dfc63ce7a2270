// Mitsuba 3 XML out: every plugin parameter written is one Mitsuba 3 documents (the table
// below names its source), the XML read back stands for the same material (the twin's
// predictions of both specs agree exactly, sums included), spectra are Mitsuba spectra
// covering Mitsuba's range, and what Mitsuba cannot express is refused naming the lobe.
#include <gtest/gtest.h>

#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "gonio/proto/error.hpp"
#include "gonio/twin/material.hpp"
#include "gonio/twin/twin.hpp"

namespace gonio::twin {
namespace {

const WavelengthGrid& grid() {
  static const auto g = WavelengthGrid::parse("400:700:50");
  return g;
}

// Mitsuba 3's documented parameters of each plugin the writer uses. Source: the Mitsuba 3
// documentation, "Plugin reference → BSDFs" (mitsuba.readthedocs.io, src/generated/
// plugins_bsdfs), one section per plugin; the scene elements from "Plugin reference →
// Shapes / Emitters / Sensors / Films" and "Scene format" (version attribute, <ref>,
// <transform>/<lookat>).
struct Documented {
  const char* source;
  std::set<std::string> params;
};
const std::map<std::string, Documented>& documented() {
  static const std::map<std::string, Documented> m{
      {"diffuse", {"Smooth diffuse material (diffuse)", {"reflectance"}}},
      {"conductor", {"Smooth conductor (conductor)", {"material", "eta", "k", "specular_reflectance"}}},
      {"roughconductor",
       {"Rough conductor material (roughconductor)",
        {"material", "eta", "k", "specular_reflectance", "distribution", "alpha", "alpha_u", "alpha_v",
         "sample_visible"}}},
      {"roughdielectric",
       {"Rough dielectric material (roughdielectric)",
        {"int_ior", "ext_ior", "specular_reflectance", "specular_transmittance", "distribution", "alpha",
         "alpha_u", "alpha_v", "sample_visible"}}},
      {"roughplastic",
       {"Rough plastic material (roughplastic)",
        {"diffuse_reflectance", "nonlinear", "int_ior", "ext_ior", "specular_reflectance", "distribution",
         "alpha", "sample_visible"}}},
      {"blendbsdf", {"Blended material (blendbsdf)", {"weight"}}},
      {"twosided", {"Two-sided BRDF adapter (twosided)", {}}},
      {"sphere", {"Sphere (sphere)", {}}},
      {"constant", {"Constant environment emitter (constant)", {"radiance"}}},
      {"perspective", {"Perspective pinhole camera (perspective)", {"fov", "to_world"}}},
      {"hdrfilm", {"High dynamic range film (hdrfilm)", {"width", "height"}}},
  };
  return m;
}

// Every <plugin type="T"> and the name="..." of its direct parameter children.
std::vector<std::pair<std::string, std::string>> plugin_parameters(const std::string& xml) {
  std::vector<std::pair<std::string, std::string>> out;
  std::vector<std::string> stack;
  const std::regex tag(R"(<(/?)(\w+)([^>]*?)(/?)>)");
  const std::regex type_attr(R"re(type="([^"]+)")re"), name_attr(R"re(name="([^"]+)")re");
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), tag); it != std::sregex_iterator(); ++it) {
    const auto& m = *it;
    if (m[1] == "/") {
      stack.pop_back();
      continue;
    }
    const std::string attrs = m[3];
    std::smatch a;
    std::string type;
    if (std::regex_search(attrs, a, type_attr)) type = a[1];
    if (std::regex_search(attrs, a, name_attr) && !stack.empty() && !stack.back().empty())
      out.emplace_back(stack.back(), a[1]);
    if (m[4] != "/") stack.push_back(type);
  }
  return out;
}

const std::vector<std::string>& exportable() {
  static const std::vector<std::string> v{
      "lambert:albedo=400:0.1,550:0.4,700:0.8",
      "mirror:reflectance=0.9",
      "conductor:alpha=0.05,eta=400:1.5,700:0.2,k=400:1.9,700:3.6",
      "beckmann:alpha=0.2,eta=0.2,k=3.9",
      "coat:alpha=0.1,ior=1.6",
      "dielectric:alpha=0.1,ior=1.5",
      "plastic:albedo=400:0.2,700:0.6,alpha=0.08,ior=1.5",
      "lambert:albedo=0.4+coat:alpha=0.05,ior=1.5",
      "lambert:albedo=0.2+conductor:alpha=0.3,eta=1.2,k=3+mirror:reflectance=0.05",
  };
  return v;
}

TEST(Mitsuba, EveryParameterIsDocumented) {
  for (const auto& spec : exportable()) {
    const auto xml = material::mitsuba_scene(spec, grid());
    for (const auto& [plugin, param] : plugin_parameters(xml)) {
      const auto it = documented().find(plugin);
      ASSERT_NE(it, documented().end()) << spec << ": plugin '" << plugin << "' is not in the table";
      EXPECT_TRUE(it->second.params.count(param))
          << spec << ": '" << param << "' is not a documented parameter of " << it->second.source;
    }
  }
}

// The XML read back is the same material: the twin predicts both specs alike, and every
// channel of f agrees at random directions.
TEST(Mitsuba, ReadBackPredictsTheSame) {
  const auto profile = InstrumentProfile::preset("gcms4");
  EstimatorOptions eo;
  eo.rel_se = 0.01;
  eo.max_samples = 1 << 14;
  for (const auto& spec : exportable()) {
    const auto back = material::spec_from_mitsuba(material::mitsuba_scene(spec, grid()));
    const auto a = make_bsdf(spec, grid()), b = make_bsdf(back, grid());
    std::vector<double> fa(grid().size()), fb(grid().size());
    for (int i = 0; i < 200; ++i) {
      const double t = 0.37 * i, p = 0.91 * i;
      const Vec3 wi = normalize(Vec3{std::sin(t), std::cos(p), 0.2 + std::abs(std::sin(0.5 * t))});
      const Vec3 wo = normalize(Vec3{std::cos(t), std::sin(p), 0.1 + std::abs(std::cos(0.3 * p))});
      a->eval(wi, wo, fa);
      b->eval(wi, wo, fb);
      for (std::size_t c = 0; c < fa.size(); ++c)
        ASSERT_NEAR(fa[c], fb[c], 1e-12 * std::max(1.0, fa[c])) << spec << " → " << back;
    }
    const Twin ta(profile, a, grid()), tb(profile, b, grid());
    const auto pa = ta.predict(Geometry::in_plane(45, 40), eo), pb = tb.predict(Geometry::in_plane(45, 40), eo);
    for (std::size_t c = 0; c < pa.beta.size(); ++c)
      EXPECT_NEAR(pa.beta[c], pb.beta[c], 1e-9 * std::max(1.0, pa.beta[c])) << spec;
  }
}

TEST(Mitsuba, SpectraAreMitsubaSpectraOverItsRange) {
  const auto xml = material::mitsuba_scene("lambert:albedo=400:0.1,550:0.4,700:0.8", grid());
  EXPECT_NE(xml.find(R"(<spectrum name="reflectance" value="360:0.1, 400:0.1, 550:0.4, 700:0.8, 830:0.8"/>)"),
            std::string::npos)
      << xml;
  EXPECT_EQ(xml.find("rgb"), std::string::npos);
}

TEST(Mitsuba, SumsAreNestedBlendsOfScaledLobes) {
  const auto xml = material::mitsuba_scene("lambert:albedo=0.4+coat:alpha=0.05,ior=1.5", grid());
  EXPECT_NE(xml.find(R"(<bsdf id="material" type="blendbsdf">)"), std::string::npos) << xml;
  EXPECT_NE(xml.find(R"(<spectrum name="reflectance" value="0.8"/>)"), std::string::npos) << xml;
  EXPECT_NE(xml.find(R"(<spectrum name="specular_reflectance" value="2"/>)"), std::string::npos) << xml;
}

TEST(Mitsuba, WhatMitsubaCannotExpressIsRefusedNamingTheLobe) {
  const std::pair<const char*, const char*> cases[] = {
      {"oren-nayar:albedo=0.5,sigma=20", "bsdf.oren-nayar"},
      {"abg:A=0.01,B=0.001,g=2", "bsdf.abg"},
      {"gltf:base_color=0.5", "bsdf.gltf"},
      {"plastic:albedo=0.5,haze=0.3", "bsdf.plastic"},
      {"dielectric:ior=1", "bsdf.dielectric"},
      {"plastic:albedo=0.5+lambert:albedo=0.1", "bsdf.plastic"},
  };
  for (const auto& [spec, field] : cases) {
    try {
      material::mitsuba_scene(spec, grid());
      ADD_FAILURE() << spec << " was written";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), Errc::unsupported) << spec;
      EXPECT_EQ(e.field(), field) << spec;
      EXPECT_NE(std::string(e.what()).find("Mitsuba 3 XML"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace gonio::twin
