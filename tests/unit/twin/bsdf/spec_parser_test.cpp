// The spec parser and factory: canonical round trips, defaults, spectra (inline, JSON,
// files), every parameter's range, unknown keys and lobes, and malformed input, which
// must give gonio::Error and never anything else.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"
#include "gonio/test/error_of.hpp"
#include "stats.hpp"

namespace gonio::twin {
namespace {

using test::dir_deg;

const WavelengthGrid& grid() {
  static const auto g = WavelengthGrid::parse("400:700:100");
  return g;
}

// π f at a fixed reflection geometry, per channel.
std::vector<double> beta(const Bsdf& b) {
  std::vector<double> f(b.channels());
  b.eval(dir_deg(20, 180), dir_deg(25, 0), f);
  for (auto& v : f) v *= kPi;
  return f;
}

Error error_of(const std::string& spec) {
  SCOPED_TRACE(spec);
  try {
    return gonio::test::error_of([&] { (void)make_bsdf(spec, grid()); });
  } catch (const std::exception& e) {
    ADD_FAILURE() << "threw a non-gonio exception: " << e.what();
    return Error(Errc::internal, e.what());
  }
}

Error json_error_of(const nlohmann::json& j) {
  SCOPED_TRACE(j.dump());
  return gonio::test::error_of([&] { (void)make_bsdf(j, grid()); });
}

TEST(Spec, CanonicalFormsListEveryParameter) {
  const std::vector<std::pair<std::string, std::string>> cases{
      {"lambert", "lambert:albedo=1"},
      {"lambert:albedo=0.8", "lambert:albedo=0.8"},
      {"mirror", "mirror:reflectance=1"},
      {"conductor", "conductor:alpha=0.1,eta=0.96,k=6.69"},
      {"conductor:k=3.9,eta=0.2,alpha=0.05", "conductor:alpha=0.05,eta=0.2,k=3.9"},
      {"beckmann:alpha=0.3", "beckmann:alpha=0.3,eta=0.96,k=6.69"},
      {"dielectric", "dielectric:alpha=0.1,ior=1.5"},
      {"oren-nayar", "oren-nayar:albedo=0.8,sigma=20"},
      {"coat", "coat:alpha=0.05,ior=1.5"},
      {" lambert : albedo = 0.5 ", "lambert:albedo=0.5"},
      {"lambert:albedo=0.5+coat:alpha=0.05,ior=1.5", "lambert:albedo=0.5+coat:alpha=0.05,ior=1.5"},
      {"lambert:albedo=0.5 + mirror", "lambert:albedo=0.5+mirror:reflectance=1"},
      {"lambert:albedo=400:0.2,700:0.8", "lambert:albedo=400:0.2,700:0.8"},
      {"conductor:eta=400:0.2, 700:0.4,k=5", "conductor:alpha=0.1,eta=400:0.2,700:0.4,k=5"},
      {"conductor:k=1e+1,eta=2E-1", "conductor:alpha=0.1,eta=0.2,k=10"},
  };
  for (const auto& [in, canonical] : cases) {
    const auto b = make_bsdf(in, grid());
    EXPECT_EQ(b->spec(), canonical) << in;
    // The canonical form builds the same model.
    const auto again = make_bsdf(b->spec(), grid());
    EXPECT_EQ(again->spec(), canonical);
    EXPECT_EQ(beta(*again), beta(*b)) << in;
  }
}

TEST(Spec, ExponentsAreNotLobeSeparators) {
  const auto b = make_bsdf("lambert:albedo=5e-1+conductor:alpha=1e-1,k=2e+1,eta=1e+0", grid());
  EXPECT_EQ(b->spec(), "lambert:albedo=0.5+conductor:alpha=0.1,eta=1,k=20");
}

TEST(Spec, DefaultsAreThoseDocumented) {
  EXPECT_EQ(beta(*make_bsdf("lambert", grid())), beta(*make_bsdf("lambert:albedo=1", grid())));
  EXPECT_EQ(beta(*make_bsdf("oren-nayar", grid())),
            beta(*make_bsdf("oren-nayar:albedo=0.8,sigma=20", grid())));
}

TEST(Spec, SpectrumIsInterpolatedAndHeldBeyondItsEnds) {
  const auto g = WavelengthGrid::parse("350,400,500,600,700,750");
  const auto b = make_bsdf("lambert:albedo=400:0.2,700:0.8", g);
  const auto v = beta(*b);
  const std::vector<double> expected{0.2, 0.2, 0.4, 0.6, 0.8, 0.8};
  for (std::size_t i = 0; i < v.size(); ++i) EXPECT_NEAR(v[i], expected[i], 1e-12) << g[i];
  // A single pair is a constant.
  EXPECT_NEAR(beta(*make_bsdf("lambert:albedo=550:0.3", g))[0], 0.3, 1e-12);
}

TEST(Spec, OrenNayarWithZeroSigmaIsLambert) {
  const auto a = beta(*make_bsdf("oren-nayar:albedo=0.6,sigma=0", grid()));
  const auto b = beta(*make_bsdf("lambert:albedo=0.6", grid()));
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i], b[i], 1e-15);
}

class SpectrumFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::path(GONIO_BINARY_DIR) / "tests" / "bsdf_spec_files";
    std::filesystem::create_directories(dir_);
  }
  std::string write(const std::string& name, const std::string& content) {
    const auto p = (dir_ / name).string();
    std::ofstream(p, std::ios::binary) << content;
    return p;
  }
  std::filesystem::path dir_;
};

TEST_F(SpectrumFile, CsvAndWhitespaceColumnsWithComments) {
  const auto csv = write("albedo.csv", "# nm,albedo\n400,0.2\r\n\n550, 0.5\n700,0.8\n");
  const auto txt = write("albedo.txt", "# measured\n  400\t0.2\n700   0.8\n");
  const auto a = make_bsdf("lambert:albedo=@" + csv, grid());
  EXPECT_EQ(a->spec(), "lambert:albedo=@" + csv);
  const auto va = beta(*a);
  EXPECT_NEAR(va[0], 0.2, 1e-12);
  EXPECT_NEAR(va[1], 0.4, 1e-12);  // 500 nm between 400 and 550
  EXPECT_NEAR(va[3], 0.8, 1e-12);
  const auto vb = beta(*make_bsdf("lambert:albedo=@" + txt + "+mirror", grid()));
  EXPECT_NEAR(vb[2], 0.6, 1e-12);
  // The canonical spec still reads the file.
  EXPECT_EQ(beta(*make_bsdf(a->spec(), grid())), va);
}

TEST_F(SpectrumFile, MalformedFilesNameTheLine) {
  const auto three = write("three.csv", "400,0.2\n500,0.3,9\n");
  auto e = error_of("lambert:albedo=@" + three);
  EXPECT_EQ(e.code(), Errc::parse_error);
  EXPECT_EQ(e.field(), "bsdf.lambert.albedo");
  EXPECT_NE(std::string(e.what()).find(":2"), std::string::npos) << e.what();

  const auto text = write("text.csv", "400,0.2\n500,abc\n");
  EXPECT_EQ(error_of("lambert:albedo=@" + text).code(), Errc::parse_error);
  const auto order = write("order.csv", "500,0.2\n400,0.3\n");
  EXPECT_EQ(error_of("lambert:albedo=@" + order).code(), Errc::parse_error);
  const auto empty = write("empty.csv", "# nothing\n\n");
  EXPECT_EQ(error_of("lambert:albedo=@" + empty).code(), Errc::parse_error);
  const auto high = write("high.csv", "400,0.2\n700,1.2\n");
  e = error_of("lambert:albedo=@" + high);
  EXPECT_EQ(e.code(), Errc::out_of_range);
  EXPECT_NE(std::string(e.what()).find("700 nm"), std::string::npos) << e.what();

  EXPECT_EQ(error_of("lambert:albedo=@" + (dir_ / "missing.csv").string()).code(), Errc::not_found);
  EXPECT_EQ(error_of("lambert:albedo=@" + dir_.string()).code(), Errc::not_found);  // a directory
}

TEST(Spec, JsonForms) {
  using nlohmann::json;
  EXPECT_EQ(make_bsdf(json("lambert:albedo=0.8"), grid())->spec(), "lambert:albedo=0.8");
  EXPECT_EQ(make_bsdf(json{{"type", "lambert"}, {"albedo", 0.8}}, grid())->spec(),
            "lambert:albedo=0.8");
  // Spectrum objects are ordered by wavelength, not by their keys' text.
  EXPECT_EQ(make_bsdf(json::parse(R"({"type":"lambert","albedo":{"1000":0.9,"400":0.2,"700":0.8}})"),
                      grid())->spec(),
            "lambert:albedo=400:0.2,700:0.8,1000:0.9");
  EXPECT_EQ(make_bsdf(json::parse(R"({"type":"conductor","eta":[[400,0.2],[700,0.4]],"k":"400:3,700:4"})"),
                      grid())->spec(),
            "conductor:alpha=0.1,eta=400:0.2,700:0.4,k=400:3,700:4");
  const auto sum = make_bsdf(
      json::parse(R"([{"type":"lambert","albedo":0.5},{"type":"coat","alpha":0.05,"ior":1.5},"mirror:reflectance=0.1"])"),
      grid());
  EXPECT_EQ(sum->spec(), "lambert:albedo=0.5+coat:alpha=0.05,ior=1.5+mirror:reflectance=0.1");
  EXPECT_EQ(beta(*sum), beta(*make_bsdf(sum->spec(), grid())));
}

TEST(Spec, JsonErrors) {
  using nlohmann::json;
  auto e = json_error_of(json{{"type", "lambert"}, {"albedo", 0.5}, {"colour", 1}});
  EXPECT_EQ(e.field(), "bsdf.lambert.colour");
  e = json_error_of(json{{"albedo", 0.5}});
  EXPECT_EQ(e.field(), "bsdf.type");
  e = json_error_of(json{{"type", "lambert"}, {"albedo", true}});
  EXPECT_EQ(e.code(), Errc::invalid_argument);
  EXPECT_EQ(e.field(), "bsdf.lambert.albedo");
  EXPECT_EQ(json_error_of(json{{"type", "lambert"}, {"albedo", 1.5}}).code(), Errc::out_of_range);
  EXPECT_EQ(json_error_of(json::array()).code(), Errc::invalid_argument);
  EXPECT_EQ(json_error_of(json(3)).code(), Errc::invalid_argument);
  EXPECT_EQ(json_error_of(json::parse(R"({"type":"lambert","albedo":{"x":1}})")).code(),
            Errc::invalid_argument);
  EXPECT_EQ(json_error_of(json::parse(R"({"type":"lambert","albedo":[[400]]})")).code(),
            Errc::invalid_argument);
  EXPECT_EQ(json_error_of(json::parse(R"({"type":"lambert","albedo":{"400":0.1,"400.0":0.2}})")).code(),
            Errc::invalid_argument);
  EXPECT_EQ(json_error_of(json::parse(R"([{"type":"lambert"}, 4])")).field(), "bsdf[1]");
  EXPECT_EQ(json_error_of(json::parse(R"({"type":"file"})")).field(), "bsdf.path");
}

struct Range {
  std::string model, key;
  double lo, hi;
  bool lo_open;
};

// The documented ranges (twin/bsdf_spec.md): the bounds are accepted (unless open), values
// just outside are out_of_range errors naming bsdf.<model>.<key>.
TEST(Spec, EveryParameterIsRangeChecked) {
  const std::vector<Range> ranges{
      {"lambert", "albedo", 0, 1, false},     {"mirror", "reflectance", 0, 1, false},
      {"conductor", "alpha", 0.001, 1, false}, {"conductor", "eta", 0, 10, true},
      {"conductor", "k", 0, 20, false},       {"beckmann", "alpha", 0.001, 1, false},
      {"beckmann", "eta", 0, 10, true},       {"beckmann", "k", 0, 20, false},
      {"dielectric", "alpha", 0.001, 1, false}, {"dielectric", "ior", 1, 4, false},
      {"oren-nayar", "albedo", 0, 1, false},  {"oren-nayar", "sigma", 0, 90, false},
      {"coat", "alpha", 0.001, 1, false},     {"coat", "ior", 1, 4, false},
  };
  const auto spec = [](const Range& r, double v) {
    return r.model + ":" + r.key + "=" + text::format_number(v);
  };
  for (const auto& r : ranges) {
    const std::string field = "bsdf." + r.model + "." + r.key;
    if (!r.lo_open) {
      EXPECT_NO_THROW((void)make_bsdf(spec(r, r.lo), grid())) << spec(r, r.lo);
    } else {
      EXPECT_NO_THROW((void)make_bsdf(spec(r, r.lo + 1e-9), grid())) << spec(r, r.lo + 1e-9);
      const auto e = error_of(spec(r, r.lo));
      EXPECT_EQ(e.code(), Errc::out_of_range);
      EXPECT_EQ(e.field(), field);
    }
    EXPECT_NO_THROW((void)make_bsdf(spec(r, r.hi), grid())) << spec(r, r.hi);
    for (double bad : {r.lo - 1e-6, r.hi + 1e-6, -1e300, 1e300}) {
      const auto e = error_of(spec(r, bad));
      EXPECT_EQ(e.code(), Errc::out_of_range) << spec(r, bad);
      EXPECT_EQ(e.field(), field);
      EXPECT_NE(std::string(e.what()).find("allowed range"), std::string::npos) << e.what();
    }
  }
  // Each point of a spectrum is checked, and the message says where.
  const auto e = error_of("lambert:albedo=400:0.5,600:1.1,700:0.5");
  EXPECT_EQ(e.code(), Errc::out_of_range);
  EXPECT_NE(std::string(e.what()).find("600 nm"), std::string::npos) << e.what();
}

TEST(Spec, UnknownKeysNameTheLobeTheKeyAndTheAllowedKeys) {
  const auto e = error_of("conductor:alpha=0.1,roughness=0.2");
  EXPECT_EQ(e.code(), Errc::invalid_argument);
  EXPECT_EQ(e.field(), "bsdf.conductor.roughness");
  const std::string msg = e.what();
  for (const char* part : {"roughness", "conductor", "alpha", "eta", "k"})
    EXPECT_NE(msg.find(part), std::string::npos) << msg;
  EXPECT_EQ(error_of("lambert:albedo=0.5+coat:alpha=0.1,eta=2").field(), "bsdf.coat.eta");
}

TEST(Spec, MalformedInputGivesErrors) {
  const std::vector<std::string> bad{
      "", "   ", "lamb", "lambert:albedo", "lambert:=0.5", "lambert:albedo=",
      "lambert:albedo=abc", "lambert:albedo=0.5,albedo=0.6", "lambert:0.5",
      "conductor:alpha=400:0.1,700:0.2",  // roughness cannot vary with wavelength
      "dielectric:ior=@some.csv", "+lambert", "lambert+", "lambert++mirror", "@",
      "lambert:albedo=nan", "lambert:albedo=inf", "lambert:albedo=400:0.5,400:0.6",
      "lambert:albedo=700:0.5,400:0.6", "lambert:albedo=400:0.5:3", "lambert:albedo=-5:0.5",
      "lambert:albedo=400:", "lambert:albedo=:0.5", "lambert:albedo=0.5,", "lambert:,albedo=1",
      "1lambert", "lambert mirror", "lambert:albedo=0.5 0.6", "lambert:albedo=@",
      std::string("lambert:albedo=0.5\0", 19), "ü:albedo=1",
      std::string(2u << 20, 'x'),
  };
  for (const auto& s : bad) {
    const auto e = error_of(s);
    EXPECT_NE(e.code(), Errc::internal) << s.substr(0, 60);
  }
}

// Random strings over the spec's alphabet: each is either a valid model or a gonio::Error.
// ('@' is left out: it would reach the file system.)
TEST(Spec, RandomInputNeverEscapesAsAnotherException) {
  const std::string alphabet = "lambertmirorcndu-yskiphaegv:=,+.0123456789e ";
  const std::vector<std::string> words{"lambert", "mirror", "conductor", "dielectric", "beckmann",
                                       "oren-nayar", "coat", "albedo", "alpha", "eta", "k",
                                       "ior", "sigma", "reflectance", "400:", "0.5", "1e+2"};
  test::Rng rng(2024);
  int valid = 0;
  for (int i = 0; i < 3000; ++i) {
    std::string s;
    const int len = static_cast<int>(rng.uniform() * 40);
    for (int j = 0; j < len; ++j) {
      if (rng.uniform() < 0.3)
        s += words[static_cast<std::size_t>(rng.uniform() * static_cast<double>(words.size()))];
      else
        s += alphabet[static_cast<std::size_t>(rng.uniform() * static_cast<double>(alphabet.size()))];
    }
    try {
      const auto b = make_bsdf(s, grid());
      ++valid;
      // Whatever was accepted evaluates to finite values and round-trips.
      for (const double v : beta(*b)) EXPECT_TRUE(std::isfinite(v)) << s;
      EXPECT_EQ(make_bsdf(b->spec(), grid())->spec(), b->spec()) << s;
    } catch (const Error& e) {
      EXPECT_NE(e.code(), Errc::internal) << s << ": " << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << s << ": " << e.what();
    }
  }
  EXPECT_GT(valid, 0);
}

TEST(Spec, EmptyGridIsRejected) {
  try {
    (void)make_bsdf("lambert", WavelengthGrid{});
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "wavelengths");
  }
}

}  // namespace
}  // namespace gonio::twin
