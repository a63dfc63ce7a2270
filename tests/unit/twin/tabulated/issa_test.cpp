// Zemax / Radiant IS-SA .bsdf: reading files laid out as the specification describes, the
// frame of the specular parametrization, write → read round trips (exact for specular
// tables, resampled for spherical ones), BTDF, XYZ content, TIS, and malformed files.
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

const std::vector<double> kAoi{0, 20, 40}, kAz{0, 90, 180}, kRad{0, 5, 20, 60};

// A value per (incidence, azimuth, radial) node; at radial 0 independent of azimuth.
double node_value(std::size_t i, std::size_t a, std::size_t r) {
  return r == 0 ? 3.0 + static_cast<double>(i)
                : 2.0 / static_cast<double>(r) + 0.1 * static_cast<double>(a) + 0.5 * static_cast<double>(i);
}

// The layout of the specification's Table 1 and its Brown Vinyl example.
std::string issa_text(std::string_view scatter = "BRDF", std::string_view extra_header = "") {
  std::string s =
      "#Data Generated for a reader test\n"
      "#3/11/2008 9:37:42 AM\n"
      "Source  Measured\n"
      "Symmetry  PlaneSymmetrical\n"
      "SpectralContent  Monochrome\n";
  s += fmt::format("ScatterType  {}\n", scatter);
  s += extra_header;
  s += "SampleRotation  1\n0\nAngleOfIncidence  3\n0\t20\t40\nScatterAzimuth 3\n0    90   180\n"
       "ScatterRadial 4\n0  5  20  60\n\nMonochrome\nDataBegin\n";
  for (std::size_t i = 0; i < kAoi.size(); ++i) {
    s += "TIS 0.5\n";
    for (std::size_t a = 0; a < kAz.size(); ++a) {
      for (std::size_t r = 0; r < kRad.size(); ++r)
        s += fmt::format("{}{:.6E}", r ? "\t" : "", node_value(i, a, r));
      s += "\n";
    }
  }
  s += "DataEnd\n";
  return s;
}

TabulatedParts read_text(const std::string& text, std::string_view name = "t.bsdf") {
  std::istringstream in(text);
  return read_issa(in, name);
}

TEST(Issa, ReadsTheSpecificationLayout) {
  const auto parts = read_text(issa_text());
  ASSERT_TRUE(parts.brdf);
  EXPECT_FALSE(parts.btdf);
  const auto& t = *parts.brdf;
  EXPECT_EQ(t.param(), TableParam::specular);
  EXPECT_TRUE(t.reduction().bilateral);
  EXPECT_TRUE(t.isotropic());
  EXPECT_TRUE(t.wavelengths().empty());
  EXPECT_EQ(t.axis(0), kAoi);
  EXPECT_EQ(t.axis(2), kRad);
  EXPECT_EQ(t.axis(3), kAz);
  for (std::size_t i = 0; i < 3; ++i)
    for (std::size_t a = 0; a < 3; ++a)
      for (std::size_t r = 0; r < 4; ++r)
        EXPECT_NEAR(t.at(i, 0, r, a, 0), node_value(i, a, r), 1e-6 * node_value(i, a, r));
}

// Radial and azimuth angles about the specular direction, azimuth 0 toward the normal: in
// the plane of measurement a receiver between the specular direction and the normal is at
// azimuth 0, one beyond the specular direction at azimuth 180.
TEST(Issa, SpecularFrameInTheInstrumentGeometry) {
  const TabulatedBsdf b(WavelengthGrid::parse("550"), read_text(issa_text()));
  double f = 0;
  const Vec3 wi = tabtest::in_plane_wi(20);
  b.eval(wi, tabtest::in_plane_wr(20), {&f, 1});
  EXPECT_NEAR(f, node_value(1, 0, 0), 1e-5);
  b.eval(wi, tabtest::in_plane_wr(15), {&f, 1});
  EXPECT_NEAR(f, node_value(1, 0, 1), 1e-5);
  b.eval(wi, tabtest::in_plane_wr(25), {&f, 1});
  EXPECT_NEAR(f, node_value(1, 2, 1), 1e-5);
  b.eval(wi, tabtest::about_mirror(wi, 20, 90), {&f, 1});
  EXPECT_NEAR(f, node_value(1, 1, 2), 1e-5);
  b.eval(wi, tabtest::about_mirror(wi, 20, 270), {&f, 1});  // PlaneSymmetrical mirror
  EXPECT_NEAR(f, node_value(1, 1, 2), 1e-5);
  // Half-way between two angles of incidence the specular peak stays on the specular
  // direction (interpolated in the specular frame).
  const Vec3 w30 = tabtest::in_plane_wi(30);
  b.eval(w30, tabtest::mirror(w30), {&f, 1});
  EXPECT_NEAR(f, 0.5 * (node_value(1, 0, 0) + node_value(2, 0, 0)), 1e-5);
}

TEST(Issa, RoundTripOfASpecularTableIsExact) {
  const auto parts = read_text(issa_text());
  std::ostringstream out;
  write_issa(out, *parts.brdf, false);
  const auto again = read_text(out.str(), "round.bsdf");
  ASSERT_TRUE(again.brdf);
  EXPECT_EQ(*again.brdf, *parts.brdf);
  EXPECT_NE(out.str().find("Symmetry\tPlaneSymmetrical"), std::string::npos);
  EXPECT_NE(out.str().find("ScatterType\tBRDF"), std::string::npos);
  // A second round trip gives the same bytes.
  std::ostringstream out2;
  write_issa(out2, *again.brdf, false);
  EXPECT_EQ(out.str(), out2.str());
}

// TIS is the directional-hemispherical integral of f·cos: ρ for a Lambertian table.
TEST(Issa, WritesTisAsTheHemisphericalIntegral) {
  const tabtest::Lambert model(WavelengthGrid::parse("550"), 0.6);
  AngularGrid ag{{0, 30, 60}, {}, tabtest::steps(0, 90, 10), {0, 90, 180}, true};
  std::ostringstream out;
  write_issa(out, tabulate(model, ag), false);
  std::istringstream in(out.str());
  std::string line;
  int count = 0;
  const double rho = 0.6 * tabtest::tint(550);
  while (std::getline(in, line))
    if (line.rfind("TIS ", 0) == 0) {
      EXPECT_NEAR(std::stod(line.substr(4)), rho, 0.005 * rho) << line;
      ++count;
    }
  EXPECT_EQ(count, 3);
}

// A spherical table written on IS-SA's specular grid and read back still describes the
// model (resampling error only).
TEST(Issa, SphericalTableResampledThroughIssa) {
  const auto grid = WavelengthGrid::parse("550");
  const tabtest::Lobes model(grid, 0.3, 0.5, 20);
  AngularGrid ag{tabtest::steps(0, 80, 10), {}, tabtest::steps(0, 90, 1), tabtest::steps(0, 180, 3),
                 true};
  std::ostringstream out;
  write_issa(out, tabulate(model, ag), false);
  const TabulatedBsdf back(grid, read_text(out.str()));
  EXPECT_EQ(back.parts().brdf->param(), TableParam::specular);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double worst = 0;
  for (int k = 0; k < 2000; ++k) {
    const double ti = 10.0 * std::floor(u(rng) * 9);
    const Vec3 wi = tabtest::in_plane_wi(ti);
    // Two draws as two statements: the order of a call's arguments is the compiler's choice,
    // and the directions tried must not depend on it.
    const double phi = 360 * u(rng);
    const Vec3 wo = sph(std::acos(u(rng)) * kRadToDeg, phi);
    double f = 0, g = 0;
    back.eval(wi, wo, {&f, 1});
    std::vector<double> gv(1);
    model.eval(wi, wo, gv);
    g = gv[0];
    worst = std::max(worst, std::abs(f - g) / (g + 0.1));
  }
  EXPECT_LT(worst, 0.05);
}

TEST(Issa, BtdfRoundTrip) {
  const auto grid = WavelengthGrid::parse("550");
  const tabtest::Lobes model(grid, 0.0, 0.0, 1, 0.7, 15);
  AngularGrid ag{tabtest::steps(0, 60, 20), {}, tabtest::steps(0, 90, 2), tabtest::steps(0, 180, 5),
                 true};
  const auto table = tabulate(model, ag, true);
  std::ostringstream out;
  write_issa(out, table, true);
  EXPECT_NE(out.str().find("ScatterType\tBTDF"), std::string::npos);
  const auto parts = read_text(out.str());
  ASSERT_TRUE(parts.btdf);
  EXPECT_FALSE(parts.brdf);
  const TabulatedBsdf b(grid, parts);
  for (const double ti : {0.0, 20.0, 40.0}) {
    const Vec3 wi = tabtest::in_plane_wi(ti);
    double f = 0;
    std::vector<double> g(1);
    b.eval(wi, -wi, {&f, 1});
    model.eval(wi, -wi, g);
    EXPECT_NEAR(f, g[0], 1e-6 * g[0]) << ti;  // radial 0 is a node
    b.eval(wi, tabtest::in_plane_wr(ti), {&f, 1});
    EXPECT_EQ(f, 0.0);  // no reflection data
  }
}

TEST(Issa, ChannelsBecomeMonochromeOrXyz) {
  const auto grid = WavelengthGrid::parse("450,550,650");
  const tabtest::Lambert model(grid, 0.5);
  AngularGrid ag{{0, 45}, {}, {0, 45, 90}, {0, 180}, true};
  const auto table = tabulate(model, ag);
  const double v450 = 0.5 * kInvPi * tabtest::tint(450), v550 = 0.5 * kInvPi * tabtest::tint(550),
               v650 = 0.5 * kInvPi * tabtest::tint(650);
  // Default: the channel mean.
  std::ostringstream mono;
  write_issa(mono, table, false);
  auto p = read_text(mono.str());
  EXPECT_NEAR(p.brdf->values().front(), (v450 + v550 + v650) / 3, 1e-12);
  // Weights, normalised.
  IssaWriteOptions o;
  o.weights = {0, 2, 2};
  std::ostringstream w;
  write_issa(w, table, false, o);
  p = read_text(w.str());
  EXPECT_NEAR(p.brdf->values().front(), (v550 + v650) / 2, 1e-12);
  // XYZ: three blocks, Y read back as grey.
  IssaWriteOptions x;
  x.xyz_weights = std::array<std::vector<double>, 3>{{{1, 0, 0}, {0.2, 0.7, 0.1}, {0, 0, 1}}};
  std::ostringstream xyz;
  write_issa(xyz, table, false, x);
  for (const char* label : {"TristimulusX", "TristimulusY", "TristimulusZ"})
    EXPECT_NE(xyz.str().find(label), std::string::npos);
  p = read_text(xyz.str());
  EXPECT_NEAR(p.brdf->values().front(), 0.2 * v450 + 0.7 * v550 + 0.1 * v650, 1e-12);
  const auto e = error_of([&] {
    IssaWriteOptions bad;
    bad.weights = {1, 1};
    std::ostringstream os;
    write_issa(os, table, false, bad);
  });
  EXPECT_EQ(e.field(), "weights");
  // One sample rotation only: an anisotropic table is refused rather than sliced.
  const tabtest::Lobes aniso(grid, 0.1, 0.3, 10, 0, 1, 1.0);
  const auto at = tabulate(aniso, AngularGrid{{0, 45}, {0, 180}, {0, 45, 90}, {0, 180}, false});
  const auto e2 = error_of([&] {
    std::ostringstream os;
    write_issa(os, at, false);
  });
  EXPECT_EQ(e2.code(), Errc::unsupported);
}

struct Bad {
  std::string name;
  std::string text;
  Errc code;
  std::string needle;  // part of the message
};

std::string replace(std::string s, const std::string& from, const std::string& to) {
  const auto pos = s.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  if (pos != std::string::npos) s.replace(pos, from.size(), to);
  return s;
}

TEST(Issa, MalformedFilesFailWithTheLine) {
  const std::string good = issa_text();
  const std::string row0 = fmt::format("{:.6E}\t{:.6E}", node_value(0, 0, 0), node_value(0, 0, 1));
  const std::vector<Bad> cases{
      {"empty", "", Errc::parse_error, "end of file"},
      {"truncated", good.substr(0, good.find("TIS", good.find("TIS") + 1)), Errc::parse_error,
       "end of file"},
      {"short row", replace(good, row0, fmt::format("{:.6E}", node_value(0, 0, 0))),
       Errc::parse_error, "ScatterRadial declares 4"},
      {"negative", replace(good, row0, "-1.0\t" + fmt::format("{:.6E}", node_value(0, 0, 1))),
       Errc::parse_error, "negative"},
      {"nan", replace(good, row0, "nan\t" + fmt::format("{:.6E}", node_value(0, 0, 1))),
       Errc::parse_error, "not finite"},
      {"garbage number", replace(good, row0, "3.0x\t1.0"), Errc::parse_error, "not a number"},
      {"huge count", replace(good, "ScatterRadial 4", "ScatterRadial 99999999999"),
       Errc::parse_error, "outside"},
      {"count without values",
       replace(good, "ScatterRadial 4\n0  5  20  60", "ScatterRadial 90000\n0 1"),
       Errc::parse_error, "not a number"},
      {"unknown keyword", replace(good, "Source  Measured", "Colour  Red"), Errc::parse_error,
       "unknown keyword 'Colour'"},
      {"missing ScatterType", replace(good, "ScatterType  BRDF\n", ""), Errc::parse_error,
       "ScatterType"},
      {"twice", replace(good, "Source  Measured", "Symmetry Asymmetrical"), Errc::parse_error,
       "given twice"},
      {"not increasing", replace(good, "0\t20\t40", "0\t40\t20"), Errc::parse_error,
       "does not increase"},
      {"incidence range", replace(good, "0\t20\t40", "0\t20\t95"), Errc::parse_error, "outside"},
      {"plane symmetric azimuth", replace(good, "0    90   180", "0    90   270"),
       Errc::parse_error, "PlaneSymmetrical"},
      {"rotations", replace(good, "SampleRotation  1\n0", "SampleRotation  2\n0 90"),
       Errc::unsupported, "sample rotations"},
      {"label", replace(good, "\nMonochrome\n", "\nTristimulusX\n"), Errc::parse_error,
       "Monochrome file"},
      {"no DataBegin", replace(good, "DataBegin\n", ""), Errc::parse_error, "DataBegin"},
      {"extra row", replace(good, "DataEnd", "1 2 3 4\nDataEnd"), Errc::parse_error,
       "expected DataEnd"},
      {"after DataEnd", good + "Monochrome\n", Errc::parse_error, "after the last DataEnd"},
      {"TIS value", replace(good, "TIS 0.5", "TIS"), Errc::parse_error, "TIS"},
      {"XYZ incomplete", replace(replace(good, "SpectralContent  Monochrome", "SpectralContent XYZ"),
                                 "\nMonochrome\n", "\nTristimulusX\n"),
       Errc::parse_error, "TristimulusX, Y and Z"},
      {"binary", std::string("\x01\x02\x00\xff\xfe garbage", 12), Errc::parse_error, "unknown keyword"},
  };
  for (const auto& c : cases) {
    const auto e = error_of([&] { read_text(c.text); });
    EXPECT_EQ(e.code(), c.code) << c.name << ": " << e.what();
    EXPECT_NE(std::string(e.what()).find(c.needle), std::string::npos) << c.name << ": " << e.what();
    EXPECT_EQ(std::string(e.what()).rfind("t.bsdf:", 0), 0u) << c.name << ": " << e.what();
  }
  // The line is the one at fault: the first data row is line 19.
  const auto e = error_of([&] { read_text(replace(good, row0, "1.0")); });
  EXPECT_NE(std::string(e.what()).find("t.bsdf:19:"), std::string::npos) << e.what();
}

TEST(Issa, MissingFile) {
  const auto e = error_of([] { read_issa(std::string("no-such-dir/none.bsdf")); });
  EXPECT_EQ(e.code(), Errc::not_found);
}

}  // namespace
}  // namespace gonio::twin
