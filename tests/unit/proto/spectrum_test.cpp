#include "gonio/proto/spectrum.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"

namespace gonio {
namespace {

TEST(WavelengthGrid, ParsesRangeSyntax) {
  const auto w = WavelengthGrid::parse("400:700:10");
  ASSERT_EQ(w.size(), 31u);
  EXPECT_EQ(w[0], 400);
  EXPECT_EQ(w[30], 700);
  EXPECT_EQ(w.to_string(), "400:700:10");
  EXPECT_EQ(WavelengthGrid::parse("555").size(), 1u);
}

TEST(WavelengthGrid, RejectsOutOfRangeAndUnordered) {
  try {
    WavelengthGrid::parse("100:700:10");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::out_of_range);
    EXPECT_EQ(e.field(), "wavelengths[0]");
    EXPECT_NE(std::string(e.what()).find("[200, 2500]"), std::string::npos);
  }
  EXPECT_THROW(WavelengthGrid::parse("500,400"), Error);
  EXPECT_THROW(WavelengthGrid::parse("500,500"), Error);
  EXPECT_THROW(WavelengthGrid::parse("200:2500:1"), Error);  // too many channels
}

TEST(Spectrum, InterpolatesAndValidates) {
  const Spectrum s(WavelengthGrid::parse("400,500,700"), {0.2, 0.4, 0.8});
  EXPECT_DOUBLE_EQ(s.at(450), 0.3);
  EXPECT_DOUBLE_EQ(s.at(600), 0.6);
  EXPECT_DOUBLE_EQ(s.at(300), 0.2);
  EXPECT_DOUBLE_EQ(s.at(900), 0.8);
  EXPECT_THROW(Spectrum(WavelengthGrid::parse("400,500"), {1.0}), Error);
  EXPECT_THROW(Spectrum(WavelengthGrid::parse("400,500"), {1.0, 2.0}, {0.1, -0.1}), Error);
}

TEST(Spectrum, JsonRoundTrip) {
  const Spectrum s(WavelengthGrid::parse("400:700:100"), {0.1, 0.2, 0.3, 0.4},
                   {0.01, 0.01, 0.02, 0.02});
  const nlohmann::json j = s;
  EXPECT_EQ(j.get<Spectrum>(), s);
  auto bad = j;
  bad["values"].push_back(0.5);
  try {
    (void)bad.get<Spectrum>();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "values");
  }
  EXPECT_EQ((nlohmann::json("400:500:50").get<WavelengthGrid>().size()), 3u);
}

}  // namespace
}  // namespace gonio
