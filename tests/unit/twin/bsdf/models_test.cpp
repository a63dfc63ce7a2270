// Every model registered in bsdf::models(), each with the same battery: its sampler against
// its pdf (chi-square), energy conservation (white furnace: ∫ f |cos θi| dωi plus the
// delta lobes' weights ≤ 1 per channel), reciprocity in reflection, and its documentation
// in twin/bsdf_spec.md (a section for the model, every parameter with its default). Each
// model runs at its defaults (from its ModelInfo) and at the extra parameter sets listed
// below. A registered model missing from the expectations fails, so a new model cannot go
// untested.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <optional>
#include <stdexcept>
#include <sstream>
#include <string>
#include <vector>

#include "chi2_cases.hpp"
#include "gonio/proto/text.hpp"
#include "stats.hpp"

// Private header of the bsdf family: the registry of models and their parameter tables.
#include "gonio/twin/detail/bsdf/model.hpp"

namespace gonio::twin {
namespace {

using test::Binning;
using test::Chi2Case;
using test::dir_deg;
using test::Side;

// A chi-square case of one model: its parameters (empty: the defaults) and the binning.
struct ModelChi2 {
  std::string params;
  double theta_o;
  Binning binning = Binning::sphere;
  double scale = 0;
  bool lossless = false;
  Side side = Side::all;
};

struct Expectations {
  std::vector<ModelChi2> chi2;       // besides the defaults' cases (default_chi2)
  std::vector<std::string> energy;   // extra parameter sets for the furnace and reciprocity
  bool below = false;                // the furnace is also run with wo below the surface
};

// What each model is tested with beyond its defaults.
const std::map<std::string, Expectations>& expectations() {
  static const std::map<std::string, Expectations> all = [] {
    std::map<std::string, Expectations> m;
    auto& lambert = m["lambert"];
    for (double t : {0.0, 45.0, 89.0, 120.0}) lambert.chi2.push_back({"albedo=0.7", t, Binning::sphere, 0, true});
    lambert.energy = {"albedo=400:0.1,700:1"};
    lambert.below = true;

    m["mirror"];  // a delta lobe only: nothing to sample; its weight is in the furnace

    auto& oren = m["oren-nayar"];
    for (double t : {30.0, 80.0, 135.0})
      oren.chi2.push_back({"albedo=0.6,sigma=30", t, Binning::sphere, 0, true});
    oren.energy = {"albedo=1,sigma=90", "albedo=400:0.3,700:0.9,sigma=20"};

    for (const char* name : {"conductor", "beckmann"}) {
      auto& e = m[name];
      for (double t : {0.0, 40.0, 80.0}) e.chi2.push_back({"alpha=0.5", t});
      for (double t : {0.0, 40.0, 80.0}) e.chi2.push_back({"alpha=0.05", t, Binning::specular, 0.15});
      for (double t : {10.0, 60.0, 87.0}) e.chi2.push_back({"alpha=0.001", t, Binning::specular, 0.003});
      e.chi2.push_back({"alpha=1", 70.0});
      e.chi2.push_back({"alpha=0.2", 150.0});  // receiver below: two-sided
    }
    m["conductor"].energy = {"alpha=0.3,eta=400:0.2,700:1.5,k=400:2,700:6",
                             "alpha=0.001,eta=0.2,k=3.9", "alpha=1,eta=10,k=0"};
    m["beckmann"].energy = {"alpha=0.3,eta=1.2,k=7", "alpha=0.01,eta=0.05,k=20"};

    // The dielectric: each receiver direction twice, binned around the reflected peak on
    // wo's side and around the refracted peak on the other side.
    auto& diel = m["dielectric"];
    const auto both = [&diel](const std::string& params, double t, double scale) {
      diel.chi2.push_back({params, t, Binning::specular, scale, false, Side::reflection});
      diel.chi2.push_back({params, t, Binning::refracted, scale, false, Side::transmission});
    };
    for (double t : {0.0, 45.0, 80.0, 120.0, 170.0}) both("alpha=0.3,ior=1.5", t, 0.5);
    for (double t : {30.0, 140.0}) both("alpha=0.02,ior=1.5", t, 0.04);
    for (double t : {45.0, 160.0}) both("alpha=0.001,ior=1.5", t, 0.002);
    both("alpha=0.1,ior=2.4", 60.0, 0.2);
    both("alpha=0.1,ior=1.33", 100.0, 0.2);  // from inside, near grazing: TIR
    diel.energy = {"alpha=0.3,ior=1.5", "alpha=0.001,ior=4", "alpha=1,ior=1.2"};
    diel.below = true;

    auto& coat = m["coat"];
    for (double t : {20.0, 75.0}) coat.chi2.push_back({"alpha=0.05,ior=1.5", t, Binning::specular, 0.15});
    coat.energy = {"alpha=0.5,ior=4"};

    // The layered diffuser: the diffuse base everywhere on the sphere, the interface's peak
    // binned around it, a hazy interface, and the furnace at the extremes (white base,
    // high index, the haze at full share).
    auto& plastic = m["plastic"];
    for (double t : {0.0, 50.0, 85.0, 130.0}) plastic.chi2.push_back({"albedo=0.8,alpha=0.3,ior=1.5", t});
    for (double t : {20.0, 70.0}) plastic.chi2.push_back({"albedo=0,alpha=0.02,ior=1.5", t, Binning::specular, 0.06});
    // (a narrow interface over a bright base is not binnable at once: the sphere binning
    // cannot resolve the peak and the peak's binning not the base; the defaults' case
    // covers the mixture at α = 0.05)
    plastic.chi2.push_back({"albedo=0.5,alpha=0.05,ior=1.6,haze=0.4,haze_alpha=0.3", 40.0});
    plastic.energy = {"albedo=1,alpha=0.001,ior=1.5", "albedo=1,alpha=1,ior=4",
                      "albedo=400:0.1,700:1,alpha=0.2,ior=1.3,haze=1,haze_alpha=0.6",
                      "albedo=1,alpha=0.3,ior=1"};
    plastic.below = true;

    // ABg: a narrow lobe (B small, binned around the peak), a broad one, Lambertian g = 0,
    // and the furnace near the energy limit.
    auto& abg = m["abg"];
    for (double t : {0.0, 40.0, 80.0}) abg.chi2.push_back({"A=0.05,B=0.05,g=1.5", t});
    abg.chi2.push_back({"A=0.2,B=0.5,g=0", 30.0});
    abg.chi2.push_back({"A=0.01,B=0.0001,g=2", 30.0, Binning::specular, 0.05});
    abg.energy = {"A=0.3,B=0.5,g=1", "A=0.3,B=1,g=0", "A=0.001,B=1e-6,g=2.5"};
    abg.below = true;

    // The glTF reference material: a rough dielectric over its diffuse base, a narrow metal
    // binned around its peak, a clearcoat over both (sampling only: a coat is not
    // reciprocal, gltf_test.cpp checks its energy), and the furnace where the specification's
    // BRDF conserves energy (a smooth white dielectric does not: gltf_test.cpp).
    auto& gltf = m["gltf"];
    for (double t : {0.0, 50.0, 85.0, 130.0})
      gltf.chi2.push_back({"base_color=0.8,metallic=0,roughness=0.6", t});
    for (double t : {20.0, 70.0})
      gltf.chi2.push_back({"metallic=1,roughness=0.2", t, Binning::specular, 0.12});
    gltf.chi2.push_back({"base_color=0.5,metallic=0,roughness=0.7,clearcoat=1,clearcoat_roughness=0.6", 40.0});
    gltf.energy = {"base_color=0.8,metallic=0,roughness=0.5", "base_color=1,metallic=1,roughness=0.03", "base_color=1,metallic=0,roughness=1,ior=4",
                   "base_color=400:0.1,700:1,metallic=0.5,roughness=0.5,specular_color=400:1,700:25"};
    gltf.below = true;
    return m;
  }();
  return all;
}

const WavelengthGrid& grid() {
  static const auto g = WavelengthGrid::parse("400:700:100");
  return g;
}

const bsdf::ModelInfo& model(const std::string& name) {
  const auto* m = bsdf::find_model(name);
  if (m == nullptr) throw std::runtime_error("no model " + name);
  return *m;
}

// "name:key=default,..." from the model's parameter table.
std::string default_spec(const bsdf::ModelInfo& m) {
  std::string s(m.name);
  for (std::size_t i = 0; i < m.params.size(); ++i)
    s += (i == 0 ? ":" : ",") + std::string(m.params[i].key) + "=" +
         text::format_number(m.params[i].fallback);
  return s;
}

std::string with(const bsdf::ModelInfo& m, const std::string& params) {
  return params.empty() ? default_spec(m) : std::string(m.name) + ":" + params;
}

// The defaults' chi-square cases: a lobe narrower than the sphere binning resolves is
// binned around its peak (3α), on each side for a transmitting model.
std::vector<Chi2Case> default_chi2(const bsdf::ModelInfo& m) {
  const auto b = make_bsdf(default_spec(m), grid());
  std::vector<Chi2Case> v;
  if (b->has_delta() && !b->sample_wi(dir_deg(30), 0.5, {0.5, 0.5})) return v;  // delta only
  double alpha = 1;
  bool refracts = false;
  for (const auto& p : m.params) {
    if (p.key == "alpha") alpha = p.fallback;
    if (p.key == "ior") refracts = true;
  }
  // Only the dielectric has `ior` and transmits; the coat's ior is for its Fresnel term.
  refracts = refracts && m.name == "dielectric";
  const std::string spec = default_spec(m);
  for (double t : {25.0, 70.0}) {
    if (alpha >= 0.3) {
      v.push_back({spec, t});
    } else if (!refracts) {
      v.push_back({spec, t, Binning::specular, 3 * alpha});
    } else {
      v.push_back({spec, t, Binning::specular, 3 * alpha, false, Side::reflection});
      v.push_back({spec, t, Binning::refracted, 3 * alpha, false, Side::transmission});
    }
  }
  return v;
}

std::vector<std::string> registered_names() {
  std::vector<std::string> v;
  for (const auto* m : bsdf::models()) v.emplace_back(m->name);
  return v;
}

std::string read_spec_doc() {
  std::ifstream in(std::string(GONIO_SOURCE_DIR) + "/twin/bsdf_spec.md");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The section of `name` in bsdf_spec.md: from its "### `name`" heading to the next heading.
std::string doc_section(const std::string& doc, const std::string& name) {
  const std::string heading = "### `" + name + "`";
  const auto a = doc.find(heading);
  if (a == std::string::npos) return {};
  const auto b = doc.find("\n#", a + heading.size());
  return doc.substr(a, b == std::string::npos ? std::string::npos : b - a);
}

// The default column of the parameter table row of `key` in `section`, if any.
std::optional<std::string> documented_default(const std::string& section, std::string_view key) {
  const std::string row = "| `" + std::string(key) + "` |";
  const auto a = section.find(row);
  if (a == std::string::npos) return std::nullopt;
  const auto end = section.find('\n', a);
  std::string line = section.substr(a, end == std::string::npos ? std::string::npos : end - a);
  while (!line.empty() && (line.back() == '|' || line.back() == ' ')) line.pop_back();
  const auto bar = line.find_last_of('|');
  std::string v = line.substr(bar + 1);
  v.erase(0, v.find_first_not_of(' '));
  return v;
}

TEST(Models, EveryRegisteredModelHasExpectations) {
  const auto names = registered_names();
  ASSERT_FALSE(names.empty());
  for (const auto& n : names)
    EXPECT_TRUE(expectations().count(n)) << "model '" << n << "' is registered but not tested: "
                                         << "add it to expectations() in " << __FILE__;
  for (const auto& [n, e] : expectations())
    EXPECT_NE(std::find(names.begin(), names.end(), n), names.end())
        << "expectations for '" << n << "', which is not a registered model";
}

class ModelTest : public ::testing::TestWithParam<std::string> {
 protected:
  const bsdf::ModelInfo& info() const { return model(GetParam()); }
  const Expectations& expected() const {
    static const Expectations none;
    const auto it = expectations().find(GetParam());
    return it == expectations().end() ? none : it->second;
  }
  std::vector<std::string> energy_specs() const {
    std::vector<std::string> v{default_spec(info())};
    for (const auto& p : expected().energy) v.push_back(with(info(), p));
    return v;
  }
};

// The defaults come from the parameter table, and the canonical spec lists them all.
TEST_P(ModelTest, DefaultsAreItsParameterTable) {
  const auto b = make_bsdf(std::string(info().name), grid());
  EXPECT_EQ(b->spec(), default_spec(info()));
}

TEST_P(ModelTest, SamplingMatchesPdf) {
  for (const auto& c : default_chi2(info())) test::expect_sampling_matches_pdf(c);
  for (const auto& c : expected().chi2)
    test::expect_sampling_matches_pdf(
        {with(info(), c.params), c.theta_o, c.binning, c.scale, c.lossless, c.side});
}

// White furnace: what is reflected and transmitted, sampled lobes and delta lobes
// together, is at most what comes in, on every channel.
TEST_P(ModelTest, AlbedoAtMostOneForEveryChannel) {
  for (const auto& spec : energy_specs()) {
    const auto b = make_bsdf(spec, grid());
    for (double t : {0.0, 30.0, 60.0, 85.0, 89.5, 120.0, 175.0}) {
      if (t > 90 && !expected().below) continue;
      const Vec3 wo = dir_deg(t, 20);
      const auto e = test::albedo_is(*b, wo, 10000, 11);
      std::vector<DeltaLobe> lobes;
      b->delta_lobes(wo, lobes);
      for (std::size_t c = 0; c < e.mean.size(); ++c) {
        double delta = 0;
        for (const auto& l : lobes) delta += l.weight[c];
        EXPECT_LE(e.mean[c] + delta, 1.0 + 4 * e.se[c] + 1e-3)
            << spec << " θo=" << t << " channel " << grid()[c] << " nm";
      }
    }
  }
}

TEST_P(ModelTest, ReflectionIsReciprocal) {
  test::Rng rng(31);
  std::vector<double> a(grid().size()), r(grid().size());
  for (const auto& spec : energy_specs()) {
    const auto b = make_bsdf(spec, grid());
    for (int i = 0; i < 300; ++i) {
      Vec3 wi = rng.sphere(), wo = rng.sphere();
      if (wi.z * wo.z < 0) wi = Vec3{wi.x, wi.y, -wi.z};  // same side: reflection
      b->eval(wi, wo, a);
      b->eval(wo, wi, r);
      for (std::size_t c = 0; c < a.size(); ++c)
        EXPECT_NEAR(a[c], r[c], 1e-10 * std::max(1.0, std::abs(a[c]))) << spec;
    }
  }
}

// bsdf_spec.md has a section for the model and documents each parameter with its default,
// in the model's own table or in the table of the model its section refers to ("as
// `conductor`").
TEST_P(ModelTest, IsDocumentedInTheSpecReference) {
  static const std::string doc = read_spec_doc();
  ASSERT_FALSE(doc.empty()) << "cannot read twin/bsdf_spec.md";
  const std::string name(info().name);
  const std::string section = doc_section(doc, name);
  ASSERT_FALSE(section.empty()) << "no '### `" << name << "`' section in twin/bsdf_spec.md";
  for (const auto& p : info().params) {
    auto documented = documented_default(section, p.key);
    if (!documented) {
      for (const auto* other : bsdf::models()) {
        if (other->name == name || section.find("`" + std::string(other->name) + "`") == std::string::npos)
          continue;
        documented = documented_default(doc_section(doc, std::string(other->name)), p.key);
        if (documented) break;
      }
    }
    ASSERT_TRUE(documented) << "parameter '" << p.key << "' of '" << name << "' is not in a table";
    EXPECT_EQ(*documented, text::format_number(p.fallback)) << name << "." << p.key;
  }
}

INSTANTIATE_TEST_SUITE_P(Registered, ModelTest, ::testing::ValuesIn(registered_names()),
                         [](const auto& p) {
                           std::string n = p.param;
                           std::replace(n.begin(), n.end(), '-', '_');
                           return n;
                         });

}  // namespace
}  // namespace gonio::twin
