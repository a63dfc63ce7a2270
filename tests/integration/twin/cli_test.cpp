// gonio-twin as a user runs it: a real process, its exit code, stdout and files.
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/arms.hpp"
#include "gonio/proto/geometry.hpp"
#include "gonio/proto/version.hpp"
#include "gonio/twin/plot.hpp"
#include "gonio/test/command.hpp"
#include "gonio/test/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;

struct Run {
  int code = -1;
  std::string out, err;
};

// Runs gonio-twin with `args` (a shell-quoted string); stderr goes to a temp file.
Run gonio_twin(const std::string& args) {
  const auto err_path = fs::temp_directory_path() / ("gonio-twin-err-" + std::to_string(::getpid()));
  const auto c = gonio::test::run_command(std::string(GONIO_BIN_DIR) + "/gonio-twin " + args + " 2>" +
                                          err_path.string());
  Run r{c.code, c.out, {}};
  std::ifstream e(err_path);
  r.err.assign(std::istreambuf_iterator<char>(e), {});
  fs::remove(err_path);
  return r;
}

using TempDir = gonio::test::TempDir;

TEST(GonioTwinCli, PredictJsonHasEveryDocumentedField) {
  const auto r = gonio_twin(
      "predict --bsdf lambert:albedo=0.6 --grid 'in=45;out=-30:30:30' --wavelengths 400:700:100 "
      "--rel-se 0.01 --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j.size(), 3u);
  for (const auto& p : j) {
    for (const char* key : {"geometry", "wavelengths_nm", "radiance_factor", "std_error",
                            "samples", "seconds", "diagnostics"})
      EXPECT_TRUE(p.contains(key)) << key;
    EXPECT_EQ(p["wavelengths_nm"].size(), 4u);
    EXPECT_NEAR(p["radiance_factor"][0].get<double>(), 0.6, 1e-9);
    EXPECT_TRUE(p["diagnostics"].contains("seen_fraction"));
  }
  EXPECT_DOUBLE_EQ(j[0]["geometry"]["theta_r"].get<double>(), -30);
}

TEST(GonioTwinCli, VersionIsTheProjectVersion) {
  const auto r = gonio_twin("--version");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "gonio-twin " + std::string(gonio::proto::kVersion) + "\n");
}

TEST(GonioTwinCli, SameSeedSameAnswer) {
  const std::string args =
      "predict --bsdf conductor:alpha=0.05,eta=0.2,k=3.9 --in 30 --out 28 --wavelengths 550 --csv";
  const auto a = gonio_twin(args + " --seed 7");
  const auto b = gonio_twin(args + " --seed 7");
  const auto c = gonio_twin(args + " --seed 8");
  ASSERT_EQ(a.code, 0) << a.err;
  EXPECT_EQ(a.out, b.out);
  EXPECT_NE(a.out, c.out);
}

TEST(GonioTwinCli, BadValuesNameTheFieldAndExitTwo) {
  auto r = gonio_twin("predict --bsdf lambert:albedo=0.5 --in 95 --out 0");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("theta_i = 95"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("[0, 89.9]"), std::string::npos) << r.err;
  r = gonio_twin("predict --bsdf lambert:albedo=1.5");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("albedo"), std::string::npos) << r.err;
  r = gonio_twin("predict --bsdf lambert:colour=1");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("colour"), std::string::npos) << r.err;
  r = gonio_twin("predict --bsdf lambert --wavelengths 100:700:10");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("wavelengths"), std::string::npos) << r.err;
  r = gonio_twin("predict --bsdf @no/such/file.bsdf");
  EXPECT_EQ(r.code, 3) << r.err;
  r = gonio_twin("frobnicate");
  EXPECT_EQ(r.code, 2);
}

TEST(GonioTwinCli, ErrorMapWritesCsvPlotAndSummary) {
  TempDir dir;
  const auto prefix = (dir.path() / "map").string();
  auto r = gonio_twin("error-map --bsdf conductor:alpha=0.05,eta=0.2,k=3.9 --grid "
                      "'in=45;out=30:60:2' --wavelengths 400:700:100 --rel-se 0.005 "
                      "--json --output " + prefix + ".csv");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto s = nlohmann::json::parse(r.out);
  // Aperture averaging flattens the specular peak.
  EXPECT_LT(s["peak_error"]["45"].get<double>(), -0.05);
  ASSERT_TRUE(fs::exists(prefix + ".csv"));
  ASSERT_TRUE(fs::exists(prefix + ".png"));  // beside the CSV unless --plot says where
  std::ifstream png(prefix + ".png", std::ios::binary);
  char magic[8];
  png.read(magic, 8);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
  std::ifstream csv(prefix + ".csv");
  std::string line;
  int rows = 0;
  while (std::getline(csv, line)) ++rows;
  EXPECT_EQ(rows, 1 + 16 * 4);  // header + geometries × channels

  // --output used to be a prefix: a name without .csv still is, with a note.
  const auto old = (dir.path() / "old").string();
  r = gonio_twin("error-map --bsdf lambert --grid 'in=45;out=30:34:2' --wavelengths 550 --rel-se 0.01 "
                 "--output " + old + " --plot " + (dir.path() / "elsewhere.svg").string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("--output is the CSV file now"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(old + ".csv"));
  EXPECT_TRUE(fs::exists(dir.path() / "elsewhere.svg"));
  EXPECT_FALSE(fs::exists(old + ".png"));
}

TEST(GonioTwinCli, PlanPrintsAGridThatParsesBack) {
  const auto r = gonio_twin("plan --bsdf conductor:alpha=0.1,eta=0.2,k=3.9 --in 45 --range 0:80 "
                            "--dense-step 1 --curve-error 0.02 --rel-se 0.002 --wavelengths 550");
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_EQ(r.out.rfind("in=45;out=0,", 0), 0u) << r.out;
  const auto line = r.out.substr(0, r.out.find('\n'));
  // Feed the plan back into predict: it must be accepted as a grid.
  const auto p = gonio_twin("predict --bsdf lambert --wavelengths 550 --rel-se 0.01 --csv --grid '" + line + "'");
  EXPECT_EQ(p.code, 0) << p.err;
  EXPECT_NE(r.err.find("points instead of 81 dense"), std::string::npos) << r.err;
}

// The planners propose only what the arms can reach (the profile's 10° clearance, on the
// side of its 0°/45° calibration geometry), so that their grids paste into a scan as they are.
TEST(GonioTwinCli, PlanAndDesignKeepToWhatTheArmsCanReach) {
  // (--tolerance, the old name of --curve-error, still works and says so.)
  auto r = gonio_twin("plan --bsdf conductor:alpha=0.1,eta=0.2,k=3.9 --in 45 --dense-step 1 "
                      "--tolerance 0.02 --rel-se 0.002 --wavelengths 550");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("--tolerance is now --curve-error"), std::string::npos) << r.err;
  const auto line = r.out.substr(0, r.out.find('\n'));
  const gonio::ArmClearance arms(10);
  const auto grid = gonio::parse_geometry_grid(line);
  ASSERT_FALSE(grid.empty());
  EXPECT_EQ(grid.front().theta_r, -35) << line;
  for (std::size_t k = 0; k < grid.size(); ++k) {
    EXPECT_TRUE(arms.clear(grid[k])) << grid[k].to_string();
    if (k > 0) {
      EXPECT_TRUE(arms.can_move(grid[k - 1], grid[k])) << grid[k].to_string();
    }
  }
  EXPECT_NE(r.err.find("below -35° left out"), std::string::npos) << r.err;
  // A candidate goniod would refuse is refused, naming it, in both modes.
  for (const std::string mode : {"--curve", "--model conductor:alpha=?,eta=0.2,k=3.9"}) {
    r = gonio_twin("design " + mode + " --bsdf conductor:alpha=0.1,eta=0.2,k=3.9 --wavelengths 550 "
                   "--grid 'in=45;out=-40:80:5' --max-points 10");
    EXPECT_NE(r.code, 0) << r.out;
    EXPECT_NE(r.err.find("candidates[0] (45/-40)"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("collision zone"), std::string::npos) << r.err;
  }
  r = gonio_twin("design --curve --bsdf conductor:alpha=0.1,eta=0.2,k=3.9 --wavelengths 550 "
                 "--grid 'in=45;out=-35:80:5' --max-points 24");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto chosen = r.out.substr(r.out.find("geometries:"));
  EXPECT_EQ(chosen.find("45/-40"), std::string::npos) << chosen;
}

// A value with its u is rounded to it (GUM §7.2.6): u to two significant digits, the value to
// the same decimal place ("0.10019 ± 0.00019", not "0.1002 ± 0.00019" or "0.02 ± 9.3e-07").
TEST(GonioTwinCli, DesignRoundsParametersToTheirUncertainty) {
  const auto r = gonio_twin("design --model 'conductor:alpha=?,eta=0.2,k=3.9' --bsdf conductor:alpha=0.1,eta=0.2,k=3.9 "
                            "--wavelengths 550 --grid 'in=45;out=-35:80:5' --max-points 10 --fit-samples 1024");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::regex value(R"(conductor\.alpha = (-?[0-9]+)\.([0-9]+) ± 0\.(0*)([1-9][0-9]?) \()");
  int lines = 0;
  for (auto it = std::sregex_iterator(r.out.begin(), r.out.end(), value); it != std::sregex_iterator(); ++it) {
    const auto& m = *it;
    // As many decimals in the value as in u, whose significant digits are at most two.
    EXPECT_EQ(m[2].length(), m[3].length() + m[4].length()) << m[0];
    ++lines;
  }
  EXPECT_EQ(lines, 2) << r.out;  // the uniform grid and the adaptive run
}

TEST(GonioTwinCli, ConvertRoundTripsThroughBothFormats) {
  TempDir dir;
  const auto ssdd = (dir.path() / "m.ssdd").string();
  const auto issa = (dir.path() / "m.bsdf").string();
  auto r = gonio_twin("convert --bsdf conductor:alpha=0.2,eta=0.2,k=3.9 --wavelengths 450,550,650 "
                      "--rel-se 0.01 --theta-step 15 --phi-step 45 --output " + ssdd);
  ASSERT_EQ(r.code, 0) << r.err;
  r = gonio_twin("convert --input " + ssdd + " --output " + issa);
  ASSERT_EQ(r.code, 0) << r.err;
  // What was written and how big: the file's own size.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.out, m, std::regex(R"(wrote (\S+) \(([0-9.]+) (B|kB|MB|GB), )"))) << r.out;
  EXPECT_EQ(m[1].str(), issa);
  const double scale = m[3] == "B" ? 1 : m[3] == "kB" ? 1e3 : m[3] == "MB" ? 1e6 : 1e9;
  EXPECT_NEAR(std::stod(m[2].str()) * scale, static_cast<double>(std::filesystem::file_size(issa)), 0.06 * scale)
      << r.out;
  // The converted table is a BSDF the twin can measure again.
  r = gonio_twin("predict --bsdf @" + issa + " --in 30 --out 30 --wavelengths 550 --rel-se 0.01 --json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_GT(nlohmann::json::parse(r.out)[0]["radiance_factor"][0].get<double>(), 1.0);
  r = gonio_twin("convert --input " + ssdd + " --output " + (dir.path() / "x.txt").string());
  EXPECT_NE(r.code, 0);
}

TEST(GonioTwinCli, ConvertToIssaWritesTheLuminanceFactor) {
  // Green-poor white: the plain channel mean is 0.6, the luminance factor (ȳ-weighted,
  // dominated by 550 nm) is near 0.3.
  TempDir dir;
  const auto issa = (dir.path() / "l.bsdf").string();
  auto r = gonio_twin("convert --bsdf lambert:albedo=450:0.8,550:0.2,650:0.8 --wavelengths 450,550,650 "
                      "--rel-se 0.01 --theta-step 15 --phi-step 45 --output " + issa);
  ASSERT_EQ(r.code, 0) << r.err;
  r = gonio_twin("predict --bsdf @" + issa + " --in 30 --out 0 --wavelengths 550 --rel-se 0.01 --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const double beta = nlohmann::json::parse(r.out)[0]["radiance_factor"][0].get<double>();
  EXPECT_GT(beta, 0.2);
  EXPECT_LT(beta, 0.4);
}

TEST(GonioTwinCli, ConvertKeepsEnergyAndColor) {
  // A glossy conductor: the file's TIS lines (its reflectance as a reader interpolates it)
  // stay below 1 up to grazing incidence, and a spectral table is written as XYZ.
  TempDir dir;
  const auto issa = (dir.path() / "g.bsdf").string();
  auto r = gonio_twin("convert --bsdf conductor:alpha=0.1,eta=0.2,k=3.9 --wavelengths 450,550,650 "
                      "--theta-step 17 --grid-error 0.02 --output " + issa);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("lobe-following grid"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(grid error 0.02)"), std::string::npos) << r.err;
  std::ifstream in(issa);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("SpectralContent\tXYZ"), std::string::npos);
  EXPECT_NE(text.find("TristimulusZ"), std::string::npos);
  std::istringstream lines(text);
  int tis = 0;
  for (std::string line; std::getline(lines, line);)
    if (line.rfind("TIS ", 0) == 0) {
      ++tis;
      EXPECT_LT(std::stod(line.substr(4)), 1.02) << line;
    }
  EXPECT_EQ(tis % 3, 0);
  EXPECT_GE(tis, 3 * 6);  // θi 0, 17, 34, 51, 68, 85 per block, and any added between them
  r = gonio_twin("convert --input " + issa + " --monochrome --output " + (dir.path() / "m.bsdf").string());
  ASSERT_EQ(r.code, 0) << r.err;
}

TEST(GonioTwinCli, RenderWritesAPng) {
  TempDir dir;
  const auto png = (dir.path() / "s.png").string();
  const auto r = gonio_twin("render --bsdf lambert:albedo=0.7 --wavelengths 450,550,650 --size 48 "
                            "--theta-step 15 --radial-step 2 --phi-step 45 --rel-se 0.01 --pixel-rel-se 0.03 "
                            "--output " + png);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_GT(fs::file_size(png), 500u);
  EXPECT_NE(r.out.find("ΔE00 measured vs true"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("rel. s.e."), std::string::npos) << r.err;  // the noise report
}

TEST(GonioTwinCli, RenderWithACorrectedTableDrawsThreeSpheresAndTwoMaps) {
  TempDir dir;
  const auto table = (dir.path() / "c.ssdd").string();
  auto r = gonio_twin("convert --bsdf lambert:albedo=0.6 --wavelengths 450,550,650 --theta-step 30 "
                      "--output " + table);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto png = (dir.path() / "s.png").string();
  r = gonio_twin("render --bsdf lambert:albedo=0.7 --wavelengths 450,550,650 --size 40 "
                 "--theta-step 15 --radial-step 2 --phi-step 45 --rel-se 0.01 --pixel-rel-se 0.03 "
                 "--environment uniform:0.3 --corrected " + table + " --json --output " + png);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j.at("spheres").size(), 3u);
  ASSERT_EQ(j.at("delta_e").size(), 2u);
  EXPECT_EQ(j.at("delta_e")[1].at("other").get<std::string>(), "corrected");
  for (const auto& d : j.at("delta_e")) {
    EXPECT_LE(d.at("mean").get<double>(), d.at("p95").get<double>() + 1e-12);
    EXPECT_LE(d.at("p95").get<double>(), d.at("max").get<double>());
  }
  // Albedo 0.6 against 0.7: a visible difference.
  EXPECT_GT(j.at("delta_e")[1].at("mean").get<double>(), 2.0);
  EXPECT_GT(j.at("spheres")[0].at("noise").at("lit_pixels").get<double>(), 500);
  const auto img = gonio::twin::read_png(png);
  EXPECT_GE(img.width, 5 * 40);
}

TEST(GonioTwinCli, RenderRefusesBadOptionsNamingTheFlag) {
  auto r = gonio_twin("render --bsdf lambert:albedo=0.7 --size 4");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--size"), std::string::npos) << r.err;
  r = gonio_twin("render --bsdf lambert:albedo=0.7 --environment fog");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--environment"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("sky"), std::string::npos) << r.err;
  r = gonio_twin("render --bsdf lambert:albedo=0.7 --environment sky:500");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("[0, 100]"), std::string::npos) << r.err;
  r = gonio_twin("render --bsdf lambert:albedo=0.7 --light-size 90");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--light-size"), std::string::npos) << r.err;
}

}  // namespace

// gonio-twin material: each format written with its report; what a format cannot express
// is refused with exit 2, the message naming the lobe and the format, and no file written.
TEST(GonioTwinCli, MaterialWritesEachFormatAndRefusesWhatItCannotExpress) {
  TempDir dir("material");
  const auto path = [&](const char* name) { return (dir.path() / name).string(); };
  auto r = gonio_twin("material --bsdf conductor:alpha=0.2,eta=0.2,k=3.9 --format merl --json --output " +
                      path("silver.binary"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(fs::file_size(path("silver.binary")), 12u + 3u * 90 * 90 * 180 * 8);
  EXPECT_LT(nlohmann::json::parse(r.out)["merl"]["max_rel"].get<double>(), 0.02) << r.out;
  r = gonio_twin("material --bsdf 'lambert:albedo=0.3+coat:alpha=0.1,ior=1.5' --format mitsuba --output " +
                 path("paint.xml"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("note: coat"), std::string::npos) << r.out;
  r = gonio_twin("material --bsdf lambert:albedo=0.5 --format gltf --no-render --json --output " + path("grey.gltf"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(nlohmann::json::parse(r.out)["gltf"].contains("delta_e_studio"));
  std::ifstream in(path("grey.gltf"));
  EXPECT_EQ(nlohmann::json::parse(in)["asset"]["version"], "2.0");
  // The material and its glTF approximation side by side, with their ΔE00 map.
  r = gonio_twin("material --bsdf conductor:alpha=0.2,eta=0.2,k=3.9 --format gltf --size 32 --pixel-rel-se 0.05 "
                 "--output " + path("silver.gltf") + " --plot " + path("silver.png"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("ΔE00 studio render"), std::string::npos) << r.out;
  EXPECT_GT(fs::file_size(path("silver.png")), 500u);
  EXPECT_EQ(gonio_twin("material --bsdf lambert --format gltf --no-render --plot " + path("no.png") + " --output " +
                       path("no.gltf")).code, 2);

  r = gonio_twin("material --bsdf oren-nayar:albedo=0.5,sigma=20 --format mitsuba --output " + path("no.xml"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("oren-nayar"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("Mitsuba 3 XML"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("no.xml")));
  EXPECT_EQ(gonio_twin("material --bsdf lambert --format obj --output " + path("x.obj")).code, 2);
  // A measured BTDF: MERL holds reflection only.
  r = gonio_twin(std::string("material --bsdf @") + GONIO_SOURCE_DIR + "/tests/fuzz/corpus/issa/btdf.bsdf --format merl --output " +
                 path("btdf.binary"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("the table transmits"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("btdf.binary")));
}
