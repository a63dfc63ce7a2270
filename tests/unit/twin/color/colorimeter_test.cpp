// Colorimetry: tables from colord-data, XYZ / CIELAB of spectra, sRGB, and errors.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include "gonio/proto/error.hpp"
#include "gonio/test/temp_dir.hpp"
#include "gonio/twin/color.hpp"

namespace gonio::twin {
namespace {

namespace fs = std::filesystem;

using TempDir = ::gonio::test::TempDir;

// Sets GONIO_COLORD_DIR for the scope of a test.
class ScopedColordDir {
 public:
  explicit ScopedColordDir(const std::string& dir) {
    if (const char* old = std::getenv("GONIO_COLORD_DIR")) old_ = old;
    ::setenv("GONIO_COLORD_DIR", dir.c_str(), 1);
  }
  ~ScopedColordDir() {
    if (old_.empty()) ::unsetenv("GONIO_COLORD_DIR");
    else ::setenv("GONIO_COLORD_DIR", old_.c_str(), 1);
  }

 private:
  std::string old_;
};

Spectrum flat(const WavelengthGrid& grid, double r) {
  return Spectrum(grid, std::vector<double>(grid.size(), r));
}

// The tables' own 5 nm sampling of the observers.
const WavelengthGrid kFine = WavelengthGrid::parse("360:830:5");
const WavelengthGrid kVisible = WavelengthGrid::parse("400:700:10");

TEST(ColorTables, ReadsObserversAndIlluminantsFromColord) {
  const auto& o10 = Observer::get(ObserverKind::cie1964_10deg);
  const auto& o2 = Observer::get(ObserverKind::cie1931_2deg);
  ASSERT_EQ(o10.wavelengths().size(), 95u);
  EXPECT_EQ(o10.wavelengths().front(), 360);
  EXPECT_EQ(o10.wavelengths().back(), 830);
  // ȳ of the 2° observer is the photopic luminosity function V(λ): its maximum (1) is at
  // 555 nm; z̄ vanishes in the red.
  EXPECT_NEAR(o2.at(555).y, 1.0, 1e-3);
  EXPECT_EQ(o2.at(700).z, 0.0);
  EXPECT_EQ(o2.at(300).x, 0.0);  // zero outside the table
  EXPECT_EQ(o2.at(900).y, 0.0);

  const auto names = Illuminant::available();
  for (const char* n : {"A", "D50", "D65", "F2"})
    EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
  const auto& d65 = Illuminant::get("d65");  // case-insensitive
  EXPECT_EQ(d65.name(), "D65");
  // Relative SPD: colord normalises to 1 at 560 nm (CIE: 100).
  EXPECT_NEAR(d65.at(560), 1.0, 1e-6);
  const auto& a = Illuminant::get("A");
  EXPECT_EQ(a.wavelengths().size(), 531u);  // 1 nm table
  EXPECT_NEAR(a.at(560), 1.0, 1e-3);
}

TEST(ColorTables, WhitePointsMatchPublishedValues) {
  // CIE 15:2004 Table T.3 (2 decimals; ASTM E308 gives the same to ±0.02).
  struct Case {
    const char* illuminant;
    ObserverKind observer;
    double x, z;
  };
  const Case cases[] = {
      {"D65", ObserverKind::cie1931_2deg, 95.04, 108.88},
      {"D65", ObserverKind::cie1964_10deg, 94.81, 107.32},
      {"D50", ObserverKind::cie1931_2deg, 96.42, 82.51},
      {"A", ObserverKind::cie1931_2deg, 109.85, 35.58},
  };
  for (const auto& c : cases) {
    const auto w = Illuminant::get(c.illuminant).white_point(Observer::get(c.observer));
    EXPECT_NEAR(w.x, c.x, 0.03) << c.illuminant;
    EXPECT_NEAR(w.y, 100.0, 1e-9) << c.illuminant;
    EXPECT_NEAR(w.z, c.z, 0.03) << c.illuminant;
  }
}

TEST(Colorimetry, PerfectWhiteIsTheIlluminantWhitePoint) {
  const auto& d65 = Illuminant::get("D65");
  const auto& o10 = Observer::get(ObserverKind::cie1964_10deg);
  const auto wp = d65.white_point(o10);
  const auto xyz = spectrum_to_xyz(flat(kFine, 1.0));  // D65 / 10° by default
  EXPECT_NEAR(xyz.x, wp.x, 1e-9);
  EXPECT_NEAR(xyz.y, 100.0, 1e-9);
  EXPECT_NEAR(xyz.z, wp.z, 1e-9);

  // On a coarse grid Y stays 100 by construction; X and Z move only a little.
  const Colorimeter coarse(kVisible);
  const auto w = coarse.xyz(flat(kVisible, 1.0));
  EXPECT_NEAR(w.y, 100.0, 1e-9);
  EXPECT_NEAR(w.x, wp.x, 1.0);
  EXPECT_NEAR(w.z, wp.z, 1.5);
  EXPECT_NEAR(coarse.white().x, w.x, 1e-9);
}

TEST(Colorimetry, WhiteIsL100AndGreyFollowsTheCieFormula) {
  for (const auto& grid : {kFine, kVisible, WavelengthGrid::parse("380,450,520,600,690")}) {
    const auto white = spectrum_to_lab(flat(grid, 1.0));
    EXPECT_NEAR(white.l, 100, 1e-9);
    EXPECT_NEAR(white.a, 0, 1e-9);
    EXPECT_NEAR(white.b, 0, 1e-9);

    // A spectrally flat 18 % grey: Y = 18, L* = 116·0.18^(1/3) − 16 (CIE 15:2004 eq. 8.3).
    const auto grey_xyz = spectrum_to_xyz(flat(grid, 0.18), "D50", ObserverKind::cie1931_2deg);
    EXPECT_NEAR(grey_xyz.y, 18.0, 1e-9);
    const auto grey = spectrum_to_lab(flat(grid, 0.18));
    EXPECT_NEAR(grey.l, 116 * std::cbrt(0.18) - 16, 1e-9);
    EXPECT_NEAR(grey.l, 49.50, 0.01);
    EXPECT_NEAR(grey.a, 0, 1e-9);
    EXPECT_NEAR(grey.b, 0, 1e-9);
  }
  // Very dark grey is on the linear branch: L* = 903.3·Y/Yn (κ = (29/3)³).
  const auto dark = spectrum_to_lab(flat(kVisible, 0.004));
  EXPECT_NEAR(dark.l, 0.004 * 24389.0 / 27.0, 1e-9);
}

TEST(Colorimetry, ColoredSpectraHaveTheExpectedHue) {
  // A reflectance rising to the red is reddish-yellow (a* > 0, b* > 0); its mirror image
  // rising to the blue has b* < 0.
  std::vector<double> red, blue;
  for (double nm : kVisible) {
    const double t = (nm - 400) / 300;
    red.push_back(0.1 + 0.8 * t);
    blue.push_back(0.9 - 0.8 * t);
  }
  const auto r = spectrum_to_lab(Spectrum(kVisible, red));
  const auto b = spectrum_to_lab(Spectrum(kVisible, blue));
  EXPECT_GT(r.a, 5);
  EXPECT_GT(r.b, 5);
  EXPECT_LT(b.b, -5);
}

TEST(Colorimetry, DeltaE2000BetweenSpectra) {
  std::vector<double> v;
  for (double nm : kVisible) v.push_back(0.3 + 0.2 * std::sin(nm / 40));
  const Spectrum s(kVisible, v);
  EXPECT_EQ(delta_e2000(s, s), 0.0);

  auto v2 = v;
  for (auto& x : v2) x *= 1.02;  // 2 % brighter
  const Spectrum s2(kVisible, v2);
  const double de = delta_e2000(s, s2);
  EXPECT_GT(de, 0.1);
  EXPECT_LT(de, 2.0);
  EXPECT_NEAR(delta_e2000(s2, s), de, 1e-9);
  // Equal to ΔE00 of the Lab values computed one by one.
  EXPECT_NEAR(de, delta_e2000(spectrum_to_lab(s), spectrum_to_lab(s2)), 1e-12);
  // The same colour on two different grids is (nearly) no difference.
  EXPECT_LT(delta_e2000(flat(kFine, 0.5), flat(kVisible, 0.5)), 1e-6);
}

TEST(Colorimetry, ColorimeterChecksItsInput) {
  const Colorimeter c(kVisible);
  EXPECT_EQ(c.illuminant(), "D65");
  EXPECT_EQ(c.observer(), ObserverKind::cie1964_10deg);
  try {
    c.xyz(flat(kFine, 1.0), "sample");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::invalid_argument);
    EXPECT_EQ(e.field(), "sample.wavelengths_nm");
  }
  const std::vector<double> three{1, 1, 1};
  EXPECT_THROW(c.xyz(three), Error);
  // An infrared-only grid has no colour.
  try {
    Colorimeter ir(WavelengthGrid::parse("1000:2000:100"));
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "wavelengths");
  }
  // One channel: weights exist, white is still Y = 100.
  const Colorimeter one(WavelengthGrid::parse("555"));
  EXPECT_NEAR(one.white().y, 100, 1e-9);
}

TEST(Colorimetry, LuminanceWeightsGiveTheLuminanceFactor) {
  const auto w = luminance_weights(kVisible.values());
  ASSERT_EQ(w.size(), kVisible.size());
  double sum = 0, y = 0;
  std::vector<double> r;
  for (std::size_t i = 0; i < w.size(); ++i) {
    // A reddish spectrum: its weighted mean must be its Y / 100, not its plain mean.
    r.push_back(kVisible.values()[i] < 580 ? 0.1 : 0.9);
    sum += w[i];
    y += w[i] * r.back();
  }
  EXPECT_NEAR(sum, 1.0, 1e-12);
  EXPECT_NEAR(y, Colorimeter(kVisible).xyz(r).y / 100, 1e-12);
  EXPECT_GT(*std::max_element(w.begin(), w.end()), 10 * w.front());  // peaks near 555 nm
  EXPECT_TRUE(luminance_weights({550}).empty());
  EXPECT_TRUE(luminance_weights({1000, 1500, 2000}).empty());
}

TEST(Colorimetry, ParsesObserverNames) {
  EXPECT_EQ(parse_observer("2"), ObserverKind::cie1931_2deg);
  EXPECT_EQ(parse_observer("10deg"), ObserverKind::cie1964_10deg);
  EXPECT_EQ(parse_observer("CIE1964"), ObserverKind::cie1964_10deg);
  try {
    parse_observer("5", "options.observer");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "options.observer");
  }
}

TEST(Srgb, D65WhiteIsNeutralAndTransferRoundTrips) {
  const auto& o2 = Observer::get(ObserverKind::cie1931_2deg);
  const auto w = Illuminant::get("D65").white_point(o2);
  const auto rgb = xyz_to_linear_srgb({w.x / 100, w.y / 100, w.z / 100});
  EXPECT_NEAR(rgb.r, 1.0, 2e-3);
  EXPECT_NEAR(rgb.g, 1.0, 2e-3);
  EXPECT_NEAR(rgb.b, 1.0, 2e-3);
  // Primaries: pure red has X > Y > Z and maps to r only.
  const auto red = xyz_to_linear_srgb({0.4124, 0.2126, 0.0193});
  EXPECT_NEAR(red.r, 1, 2e-3);
  EXPECT_NEAR(red.g, 0, 2e-3);
  EXPECT_NEAR(red.b, 0, 2e-3);
  for (double x : {0.0, 0.001, 0.0031308, 0.01, 0.18, 0.5, 1.0})
    EXPECT_NEAR(srgb_decode(srgb_encode(x)), x, 1e-12) << x;
  EXPECT_NEAR(srgb_encode(0.18), 0.4613, 1e-4);  // mid grey ≈ 118/255
  EXPECT_EQ(srgb_encode(-1.0), 0.0);
  EXPECT_NEAR(srgb_encode(2.0), 1.0, 1e-12);
}

TEST(ColorErrors, MissingFilesNameTheFileAndThePackage) {
  const std::string dir = "/nonexistent/gonio-colord";
  try {
    Observer::load(ObserverKind::cie1964_10deg, dir);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::not_found);
    const std::string msg = e.what();
    EXPECT_NE(msg.find("CIE1964-10deg-XYZ.cmf"), std::string::npos) << msg;
    EXPECT_NE(msg.find("colord-data"), std::string::npos) << msg;
  }
  try {
    Illuminant::load("D65", dir);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::not_found);
    EXPECT_NE(std::string(e.what()).find("colord-data"), std::string::npos) << e.what();
  }
  try {
    Illuminant::load("D99");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::not_found);
    EXPECT_NE(std::string(e.what()).find("D65"), std::string::npos) << e.what();  // lists names
  }
  EXPECT_THROW(Illuminant::load("../cmf/x"), Error);
}

TEST(ColorErrors, EnvironmentOverridesTheDirectory) {
  const TempDir tmp;
  tmp.write("illuminant/CIE-FLAT.sp",
            "SPECT\nSPECTRAL_START_NM\t380.0\nSPECTRAL_END_NM\t780.0\nSPECTRAL_BANDS\t3\n"
            "NUMBER_OF_FIELDS\t3\nNUMBER_OF_SETS\t1\nBEGIN_DATA_FORMAT\n SPEC_380 SPEC_580 "
            "SPEC_780\nEND_DATA_FORMAT\nBEGIN_DATA\n 1.0 2.0\n 3.0\nEND_DATA\n");
  const ScopedColordDir env(tmp.path().string());
  EXPECT_EQ(colord_dir(), tmp.path().string());
  const auto& flat_ill = Illuminant::get("flat");
  EXPECT_EQ(flat_ill.wavelengths(), (std::vector<double>{380, 580, 780}));
  EXPECT_DOUBLE_EQ(flat_ill.at(480), 1.5);
  EXPECT_EQ(flat_ill.at(800), 0.0);
  // No observer tables in this directory.
  try {
    Observer::get(ObserverKind::cie1931_2deg);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::not_found);
  }
}

TEST(ColorErrors, MalformedTablesNameFileAndLine) {
  const TempDir tmp;
  const std::string head =
      "SPECT\nSPECTRAL_START_NM\t380.0\nSPECTRAL_END_NM\t780.0\nSPECTRAL_BANDS\t3\n"
      "BEGIN_DATA_FORMAT\n SPEC_380 SPEC_580 SPEC_780\nEND_DATA_FORMAT\n";
  struct Case {
    const char* name;
    std::string text;
    std::string where;  // "file:line" expected in the message
  };
  const Case cases[] = {
      {"BADNUM", head + "BEGIN_DATA\n 1.0 x 3.0\nEND_DATA\n", "CIE-BADNUM.sp:9"},
      {"SHORT", head + "BEGIN_DATA\n 1.0 2.0\nEND_DATA\n", "CIE-SHORT.sp:8"},
      {"NOEND", head + "BEGIN_DATA\n 1.0 2.0 3.0\n", "CIE-NOEND.sp:9"},
      {"NOFMT", "SPECT\nBEGIN_DATA\n1\nEND_DATA\n", "CIE-NOFMT.sp:2"},
      {"BANDS",
       "SPECT\nSPECTRAL_START_NM 380\nSPECTRAL_END_NM 780\nSPECTRAL_BANDS 4\n"
       "BEGIN_DATA_FORMAT\nA B C\nEND_DATA_FORMAT\nBEGIN_DATA\n1 2 3\nEND_DATA\n",
       "CIE-BANDS.sp:4"},
      {"NOSTART",
       "SPECT\nSPECTRAL_END_NM 780\nSPECTRAL_BANDS 3\n"
       "BEGIN_DATA_FORMAT\nA B C\nEND_DATA_FORMAT\nBEGIN_DATA\n1 2 3\nEND_DATA\n",
       "SPECTRAL_START_NM"},
      {"QUOTE", "SPECT\nDISPLAY \"open\n", "CIE-QUOTE.sp:2"},
      {"EMPTY", "", "empty"},
  };
  for (const auto& c : cases) {
    tmp.write(std::string("illuminant/CIE-") + c.name + ".sp", c.text);
    try {
      Illuminant::load(c.name, tmp.path().string());
      ADD_FAILURE() << c.name << " was accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), Errc::parse_error) << c.name << ": " << e.what();
      EXPECT_NE(std::string(e.what()).find(c.where), std::string::npos)
          << c.name << ": " << e.what();
    }
  }
  // A CMF file with one set instead of three.
  tmp.write("cmf/CIE1931-2deg-XYZ.cmf", head + "BEGIN_DATA\n 1 2 3\nEND_DATA\n");
  try {
    Observer::load(ObserverKind::cie1931_2deg, tmp.path().string());
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::parse_error);
    EXPECT_NE(std::string(e.what()).find("CIE1931-2deg-XYZ.cmf:8"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace gonio::twin
