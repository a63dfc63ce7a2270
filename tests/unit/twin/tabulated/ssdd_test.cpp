// SSDD: files written as the specification lays them out (every data type, colour model and
// parametrization), write → read round trips in ASCII and binary, and malformed files.
#include <cstring>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf_io.hpp"
#include "tab_testing.hpp"

namespace gonio::twin {
namespace {

using tabtest::error_of;
using tabtest::sph;

TabulatedParts read_text(const std::string& text) {
  std::istringstream in(text);
  return read_ssdd(in, "t.ssdd");
}

TEST(Ssdd, SingleSampleLambertian) {
  const auto parts = read_text(
      "VERSION 0.2\n\nDATA_TYPE brdf\nCOLOR_MODEL monochrome\nPARAM_TYPE "
      "spherical_coordinate_system\nPARAM0_LIST 0\nPARAM2_LIST 0\nPARAM3_LIST 0\nDATA ascii\n"
      "0.2546\n");
  ASSERT_TRUE(parts.brdf);
  const TabulatedBsdf b(WavelengthGrid::parse("450,650"), parts);
  std::vector<double> f(2);
  b.eval(sph(35, 10), sph(70, 200), f);
  EXPECT_DOUBLE_EQ(f[0], 0.2546);
  EXPECT_DOUBLE_EQ(f[1], 0.2546);
}

// One file with all four data types, each in another colour model and parametrization.
const char* kMaterial =
    "# a material with every data type\n"
    "VERSION 0.2\n"
    "SOFTWARE test\n"
    "DATE 2024-01-02\n"
    "\n"
    "# Bluish diffuse BRDF\n"
    "DATA_TYPE brdf\n"
    "COLOR_MODEL rgb\n"
    "PARAM_TYPE half_difference_coordinate_system\n"
    "REDUCTION_TYPE bilateral_symmetry reciprocity\n"
    "PARAM0_LIST 0 90\n"
    "PARAM2_LIST 0 90\n"
    "PARAM3_LIST 0 90\n"
    "NAME blue paint\n"
    "SOURCE_TYPE generated\n"
    "DATA ascii\n"
    "# PARAM3: 0\n"
    "# PARAM2: 0\n"
    "0.01 0.05 0.16\n"
    "0.01 0.05 0.16\n"
    "# PARAM2: 90\n"
    "0.01 0.05 0.16\n"
    "0.01 0.05 0.16\n"
    "# PARAM3: 90\n"
    "0.01 0.05 0.16\n0.01 0.05 0.16\n0.01 0.05 0.16\n0.01 0.05 0.16\n"
    "\n"
    "DATA_TYPE btdf\n"
    "COLOR_MODEL xyz\n"
    "PARAM_TYPE specular_coordinate_system\n"
    "REDUCTION_TYPE bilateral_symmetry\n"
    "PARAM0_LIST 0 90\n"
    "PARAM2_LIST 0 180\n"
    "PARAM3_LIST 0 180\n"
    "DATA ascii\n"
    "0.11 0.08 0.02\n0.11 0.08 0.02\n0.11 0.08 0.02\n0.11 0.08 0.02\n"
    "0.11 0.08 0.02\n0.11 0.08 0.02\n0.11 0.08 0.02\n0.11 0.08 0.02\n"
    "\n"
    "DATA_TYPE specular_reflectance\n"
    "COLOR_MODEL spectrum\n"
    "WAVELENGTH_LIST 400 500 600 700\n"
    "PARAM0_LIST 0 90\n"
    "DATA ascii\n"
    "0.04 0.04 0.05 0.06\n"
    "0.9 0.9 0.9 0.9\n"
    "\n"
    "DATA_TYPE specular_transmittance\n"
    "COLOR_MODEL monochrome\n"
    "PARAM0_LIST 0 90\n"
    "DATA ascii\n"
    "0.5\n"
    "0\n";

TEST(Ssdd, EveryDataTypeColorModelAndParametrization) {
  const auto p = read_text(kMaterial);
  ASSERT_TRUE(p.brdf && p.btdf && p.specular_reflectance && p.specular_transmittance);
  EXPECT_EQ(p.name, "blue paint");
  // rgb → three-point spectrum, blue first.
  EXPECT_EQ(p.brdf->param(), TableParam::half_difference);
  EXPECT_TRUE(p.brdf->reduction().bilateral && p.brdf->reduction().reciprocal);
  EXPECT_EQ(p.brdf->wavelengths(), std::vector<double>(kRgbWavelengthsNm.begin(), kRgbWavelengthsNm.end()));
  EXPECT_DOUBLE_EQ(p.brdf->at(0, 0, 0, 0, 0), 0.16);
  EXPECT_DOUBLE_EQ(p.brdf->at(0, 0, 0, 0, 2), 0.01);
  // xyz → Y as grey.
  EXPECT_EQ(p.btdf->param(), TableParam::specular);
  EXPECT_TRUE(p.btdf->wavelengths().empty());
  EXPECT_DOUBLE_EQ(p.btdf->values().front(), 0.08);
  EXPECT_EQ(p.specular_reflectance->wavelengths().size(), 4u);
  EXPECT_TRUE(p.specular_transmittance->wavelengths().empty());

  const TabulatedBsdf b(WavelengthGrid::parse("464.3,611.5"), p);
  std::vector<double> f(2);
  b.eval(sph(30, 0), sph(40, 100), f);
  EXPECT_NEAR(f[0], 0.16, 1e-12);
  EXPECT_NEAR(f[1], 0.01, 1e-12);
  b.eval(sph(30, 0), tabtest::flip(sph(40, 100)), f);
  EXPECT_NEAR(f[0], 0.08, 1e-12);
  std::vector<DeltaLobe> lobes;
  b.delta_lobes(sph(45, 0), lobes);
  ASSERT_EQ(lobes.size(), 2u);
  EXPECT_NEAR(lobes[1].weight[0], 0.25, 1e-12);  // transmittance 0.5 → 0 over 0…90°
}

TabulatedParts mixed_parts() {
  const auto grid = WavelengthGrid::parse("420:680:65");
  TabulatedParts p;
  const tabtest::Lobes aniso(grid, 0.1, 0.4, 12, 0, 1, 1.5);
  AngularGrid ag{{0, 30, 60}, {0, 90, 180, 270}, tabtest::steps(0, 90, 15), tabtest::steps(0, 330, 30),
                 false};
  p.brdf = tabulate(aniso, ag);
  const tabtest::Lobes trans(WavelengthGrid::parse("550"), 0, 0, 1, 0.5, 10);
  p.btdf = tabtest::specular_table(trans, {0, 25, 50}, {0, 2, 10, 30, 90}, {0, 90, 180}, true, true);
  p.specular_reflectance =
      SpecularTable({0, 45, 89}, {}, {450, 550, 650},
                    {0.04, 0.05, 0.06, 0.05, 0.06, 0.07, 0.8, 0.85, 0.9});
  p.name = "round trip\nwith a newline";
  return p;
}

TEST(Ssdd, AsciiRoundTripIsExact) {
  auto p = mixed_parts();
  std::ostringstream out;
  SsddWriteOptions o;
  o.comment = "written by a test";
  o.date = "2024-05-06";
  o.name_entry = true;
  write_ssdd(out, p, o);
  const auto back = read_text(out.str());
  p.name = "round trip with a newline";
  EXPECT_EQ(back, p);
  EXPECT_NE(out.str().find("# written by a test\nVERSION 0.3\n"), std::string::npos);
  EXPECT_NE(out.str().find("PARAM1_LIST 0 90 180 270"), std::string::npos);
}

TEST(Ssdd, BinaryRoundTripKeepsFloatPrecision) {
  const auto p = mixed_parts();
  std::ostringstream out;
  SsddWriteOptions o;
  o.data = SsddData::binary;
  write_ssdd(out, p, o);
  const auto back = read_text(out.str());
  ASSERT_TRUE(back.brdf && back.btdf && back.specular_reflectance);
  EXPECT_EQ(back.brdf->axes(), p.brdf->axes());
  EXPECT_EQ(back.brdf->wavelengths(), p.brdf->wavelengths());
  ASSERT_EQ(back.brdf->values().size(), p.brdf->values().size());
  for (std::size_t i = 0; i < p.brdf->values().size(); ++i)
    EXPECT_NEAR(back.brdf->values()[i], p.brdf->values()[i], 1e-7 * p.brdf->values()[i] + 1e-37);
  EXPECT_EQ(back.btdf->reduction(), p.btdf->reduction());
  for (std::size_t i = 0; i < p.btdf->values().size(); ++i)
    EXPECT_NEAR(back.btdf->values()[i], p.btdf->values()[i], 1e-7 * p.btdf->values()[i] + 1e-37);
  // Float32 little-endian: the first value of the BRDF block, byte for byte.
  const std::string s = out.str();
  const auto pos = s.find("DATA binary\n");
  ASSERT_NE(pos, std::string::npos);
  const auto v = static_cast<float>(p.brdf->values()[0]);
  unsigned char expect[4];
  std::memcpy(expect, &v, 4);  // the test machine is little-endian (x86-64, aarch64)
  EXPECT_EQ(std::memcmp(s.data() + pos + 12, expect, 4), 0);
}

TEST(Ssdd, CommentsAndCrlfAreAccepted) {
  const auto parts = read_text(
      "# comment\r\nVERSION 0.1\r\n# another\r\nDATA_TYPE brdf\r\nCOLOR_MODEL monochrome\r\n"
      "PARAM_TYPE spherical_coordinate_system\r\nPARAM0_LIST 0 45\r\nPARAM2_LIST 0\r\n"
      "PARAM3_LIST 0\r\nDATA ascii\r\n# PARAM3: 0\r\n0.1\r\n\r\n  0.2  \r\n");
  ASSERT_TRUE(parts.brdf);
  EXPECT_DOUBLE_EQ(parts.brdf->values()[1], 0.2);
  // Control characters inside a NAME read as spaces, as the writer writes them.
  const auto named = read_text(
      "VERSION 0.2\nDATA_TYPE brdf\nCOLOR_MODEL monochrome\nPARAM_TYPE "
      "spherical_coordinate_system\nPARAM0_LIST 0\nPARAM2_LIST 0\nPARAM3_LIST 0\n"
      "NAME  red\r\x01paint \r\nDATA ascii\n0.1\n");
  EXPECT_EQ(named.name, "red  paint");
}

std::string with(std::string s, const std::string& from, const std::string& to) {
  const auto pos = s.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  if (pos != std::string::npos) s.replace(pos, from.size(), to);
  return s;
}

TEST(Ssdd, MalformedFilesFailWithTheLine) {
  const std::string good = kMaterial;
  struct Case {
    std::string name, text;
    Errc code;
    std::string needle;
  };
  std::string big = "VERSION 0.2\nDATA_TYPE brdf\nCOLOR_MODEL monochrome\nPARAM_TYPE "
                    "spherical_coordinate_system\n";
  for (const char* k : {"PARAM0_LIST", "PARAM1_LIST", "PARAM2_LIST", "PARAM3_LIST"}) {
    big += k;
    for (int i = 0; i <= 90; ++i) big += fmt::format(" {}", i * (k[5] == '1' || k[5] == '3' ? 4 : 1));
    big += "\n";
  }
  big += "DATA ascii\n0.1\n";
  const std::vector<Case> cases{
      {"empty", "", Errc::parse_error, "VERSION"},
      {"no version", good.substr(good.find("SOFTWARE")), Errc::parse_error, "starts with VERSION"},
      {"version 1", with(good, "VERSION 0.2", "VERSION 1.0"), Errc::unsupported, "not supported"},
      {"bad version", with(good, "VERSION 0.2", "VERSION two"), Errc::parse_error, "major"},
      {"unknown entry", with(good, "SOURCE_TYPE generated", "COLOUR blue"), Errc::parse_error,
       "unknown SSDD entry"},
      {"no PARAM_TYPE", with(good, "PARAM_TYPE half_difference_coordinate_system\n", ""),
       Errc::parse_error, "half_difference"},
      {"order", with(good, "PARAM0_LIST 0 90\nPARAM2_LIST 0 90", "PARAM2_LIST 0 90\nPARAM0_LIST 0 90"),
       Errc::parse_error, "out of order"},
      {"twice", with(good, "NAME blue paint", "NAME a\nNAME b"), Errc::parse_error, "twice"},
      {"no colour", with(good, "COLOR_MODEL rgb\n", ""), Errc::parse_error, "COLOR_MODEL"},
      {"spectrum without wavelengths", with(good, "WAVELENGTH_LIST 400 500 600 700\n", ""),
       Errc::parse_error, "WAVELENGTH_LIST"},
      {"short line", with(good, "0.01 0.05 0.16\n", "0.01 0.05\n"), Errc::parse_error,
       "needs 3"},
      {"negative", with(good, "0.01 0.05 0.16\n", "0.01 -0.05 0.16\n"), Errc::parse_error,
       "negative"},
      {"nan", with(good, "0.01 0.05 0.16\n", "0.01 nan 0.16\n"), Errc::parse_error, "not finite"},
      {"specular above one", with(good, "0.9 0.9 0.9 0.9", "0.9 1.9 0.9 0.9"), Errc::parse_error,
       "exceeds 1"},
      {"missing lines", good.substr(0, good.find("0.5\n0\n")) + "0.5\n", Errc::parse_error,
       "end of file after 1 of 2"},
      {"too many lists", big, Errc::parse_error, "more than"},
      {"reciprocity", with(good, "REDUCTION_TYPE bilateral_symmetry\n",
                           "REDUCTION_TYPE reciprocity\n"),
       Errc::parse_error, "reciprocity"},
      {"param4", with(good, "PARAM3_LIST 0 180\n", "PARAM3_LIST 0 180\nPARAM4_LIST 0 -10\n"),
       Errc::unsupported, "PARAM4"},
      {"half-difference btdf", with(good, "PARAM_TYPE specular_coordinate_system",
                                    "PARAM_TYPE half_difference_coordinate_system"),
       Errc::unsupported, "btdf"},
      {"block twice", good + "DATA_TYPE brdf\n", Errc::parse_error, "second brdf"},
      {"bad type", with(good, "DATA_TYPE btdf", "DATA_TYPE bxdf"), Errc::parse_error, "bxdf"},
      {"no DATA", good.substr(0, good.find("DATA ascii")), Errc::parse_error, "no DATA"},
      {"data mode", with(good, "DATA ascii", "DATA hex"), Errc::parse_error, "ascii or binary"},
      {"angle range", with(good, "PARAM2_LIST 0 180", "PARAM2_LIST 0 190"), Errc::parse_error,
       "outside"},
      {"bilateral range", with(good, "PARAM3_LIST 0 180", "PARAM3_LIST 0 270"), Errc::parse_error,
       "outside"},
      {"not increasing", with(good, "PARAM0_LIST 0 90\nPARAM2", "PARAM0_LIST 90 0\nPARAM2"),
       Errc::parse_error, "does not increase"},
      {"binary short", "VERSION 0.2\nDATA_TYPE brdf\nCOLOR_MODEL monochrome\nPARAM_TYPE "
                       "spherical_coordinate_system\nPARAM0_LIST 0 10\nPARAM2_LIST 0\n"
                       "PARAM3_LIST 0\nDATA binary\n\x01\x02\x03",
       Errc::parse_error, "binary data end"},
      {"binary nan", std::string("VERSION 0.2\nDATA_TYPE brdf\nCOLOR_MODEL monochrome\nPARAM_TYPE "
                                 "spherical_coordinate_system\nPARAM0_LIST 0\nPARAM2_LIST 0\n"
                                 "PARAM3_LIST 0\nDATA binary\n") +
                         std::string("\x00\x00\xc0\x7f", 4),
       Errc::parse_error, "finite"},
      {"garbage", std::string("\x7f" "ELF\x02\x01\x01\x00", 8), Errc::parse_error, "VERSION"},
  };
  for (const auto& c : cases) {
    const auto e = error_of([&] { read_text(c.text); });
    EXPECT_EQ(e.code(), c.code) << c.name << ": " << e.what();
    EXPECT_NE(std::string(e.what()).find(c.needle), std::string::npos) << c.name << ": " << e.what();
    EXPECT_EQ(std::string(e.what()).rfind("t.ssdd:", 0), 0u) << c.name << ": " << e.what();
  }
  // The first short data line of the material is line 19.
  const auto e = error_of([&] { read_text(with(good, "0.01 0.05 0.16\n", "0.01 0.05\n")); });
  EXPECT_NE(std::string(e.what()).find("t.ssdd:19:"), std::string::npos) << e.what();
}

}  // namespace
}  // namespace gonio::twin
