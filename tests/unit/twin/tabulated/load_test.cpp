// load_bsdf_file / read_bsdf_file / write_bsdf_file: dispatch by extension through real files
// on disk, and the errors for unknown extensions, missing files and parts a format cannot hold.
#include <bit>
#include <cstdint>
#include <fstream>

#include <gtest/gtest.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf_io.hpp"
#include "tab_testing.hpp"

namespace gonio::twin {
namespace {

using tabtest::error_of;

TabulatedParts glossy_parts(bool transmission) {
  const tabtest::Lobes model(WavelengthGrid::parse("450,550,650"), 0.2, 0.4, 15, 0.3, 8);
  AngularGrid ag{{0, 30, 60}, {}, tabtest::steps(0, 90, 10), tabtest::steps(0, 180, 30), true};
  return tabulate_parts(model, ag, true, transmission);
}

TEST(LoadBsdfFile, DispatchesByExtension) {
  const tabtest::ScratchDir dir;
  const auto grid = WavelengthGrid::parse("500,600");
  const auto parts = glossy_parts(true);

  const auto ssdd = dir.file("sample.SSDD");  // case-insensitive
  write_bsdf_file(ssdd, parts);
  const auto b = load_bsdf_file(ssdd, grid);
  ASSERT_TRUE(b);
  EXPECT_EQ(b->spec(), "@" + ssdd);
  EXPECT_EQ(b->channels(), 2u);
  const auto* t = dynamic_cast<const TabulatedBsdf*>(b.get());
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->parts(), parts);

  TabulatedParts only_brdf = parts;
  only_brdf.btdf.reset();
  const auto bsdf = dir.file("sample.bsdf");
  write_bsdf_file(bsdf, only_brdf);
  const auto issa = read_bsdf_file(bsdf);
  ASSERT_TRUE(issa.brdf);
  EXPECT_EQ(issa.brdf->param(), TableParam::specular);

  // A MERL file written by hand.
  const auto merl = dir.file("tiny.binary");
  {
    std::ofstream out(merl, std::ios::binary);
    const auto put = [&](auto v) {
      const auto u = std::bit_cast<std::conditional_t<sizeof(v) == 4, std::uint32_t, std::uint64_t>>(v);
      for (std::size_t k = 0; k < sizeof(v); ++k) out.put(static_cast<char>((u >> (8 * k)) & 0xff));
    };
    for (const std::int32_t d : {2, 2, 2}) put(d);
    for (int k = 0; k < 24; ++k) put(750.0);
  }
  const auto m = load_bsdf_file(merl, grid);
  std::vector<double> f(2);
  m->eval(tabtest::sph(20, 0), tabtest::sph(30, 150), f);
  // 500 nm lies between the blue and green points of the three-point spectrum.
  const double w = (500 - kRgbWavelengthsNm[0]) / (kRgbWavelengthsNm[1] - kRgbWavelengthsNm[0]);
  EXPECT_NEAR(f[0], (1 - w) * 0.5 * 1.66 + w * 0.5 * 1.15, 1e-12);
  const double w2 = (600 - kRgbWavelengthsNm[1]) / (kRgbWavelengthsNm[2] - kRgbWavelengthsNm[1]);
  EXPECT_NEAR(f[1], (1 - w2) * 0.5 * 1.15 + w2 * 0.5, 1e-12);
}

TEST(LoadBsdfFile, Errors) {
  const tabtest::ScratchDir dir;
  const auto grid = WavelengthGrid::parse("550");
  auto e = error_of([&] { load_bsdf_file(dir.file("sample.xml"), grid); });
  EXPECT_EQ(e.code(), Errc::invalid_argument);
  EXPECT_NE(std::string(e.what()).find(".bsdf"), std::string::npos);
  EXPECT_NE(std::string(e.what()).find(".ssdd"), std::string::npos);
  EXPECT_NE(std::string(e.what()).find(".binary"), std::string::npos);
  e = error_of([&] { load_bsdf_file(dir.file("missing.ssdd"), grid); });
  EXPECT_EQ(e.code(), Errc::not_found);
  // IS-SA holds one scatter type and no ideal specular part.
  e = error_of([&] { write_bsdf_file(dir.file("both.bsdf"), glossy_parts(true)); });
  EXPECT_EQ(e.code(), Errc::unsupported);
  TabulatedParts spec = glossy_parts(false);
  spec.specular_reflectance = SpecularTable({0, 90}, {}, {}, {0.04, 1.0});
  e = error_of([&] { write_bsdf_file(dir.file("spec.bsdf"), spec); });
  EXPECT_EQ(e.code(), Errc::unsupported);
  e = error_of([&] { write_bsdf_file(dir.file("x.txt"), spec); });
  EXPECT_EQ(e.code(), Errc::invalid_argument);
  // A malformed file on disk names its path.
  const auto bad = dir.file("bad.ssdd");
  std::ofstream(bad) << "VERSION 0.2\nDATA_TYPE brdf\nCOLOR_MODEL grey\n";
  e = error_of([&] { load_bsdf_file(bad, grid); });
  EXPECT_EQ(e.code(), Errc::parse_error);
  EXPECT_NE(std::string(e.what()).find(bad + ":3:"), std::string::npos) << e.what();
}

}  // namespace
}  // namespace gonio::twin
