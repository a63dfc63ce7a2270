#include "gonio/proto/text.hpp"

#include <gtest/gtest.h>

#include "gonio/proto/error.hpp"

namespace gonio::text {
namespace {

TEST(Text, ParsesNumbersStrictly) {
  EXPECT_DOUBLE_EQ(parse_double("x", " 45.5 "), 45.5);
  EXPECT_DOUBLE_EQ(parse_double("x", "+3"), 3);
  EXPECT_DOUBLE_EQ(parse_double("x", "-1e-3"), -1e-3);
  for (const char* bad : {"", "abc", "1.2.3", "45deg", "nan", "inf"}) {
    try {
      parse_double("grid.in", bad);
      ADD_FAILURE() << bad;
    } catch (const Error& e) {
      EXPECT_EQ(e.field(), "grid.in");
      EXPECT_EQ(e.code(), Errc::invalid_argument);
    }
  }
}

TEST(Text, ExpandsRangesInclusively) {
  EXPECT_EQ(parse_value_list("w", "400:700:100"), (std::vector<double>{400, 500, 600, 700}));
  EXPECT_EQ(parse_value_list("w", "0:1:0.1").size(), 11u);
  EXPECT_DOUBLE_EQ(parse_value_list("w", "0:1:0.1")[3], 0.3);
  EXPECT_EQ(parse_value_list("w", "1,5:7:1, 10"), (std::vector<double>{1, 5, 6, 7, 10}));
  EXPECT_EQ(parse_value_list("w", "0:10:3"), (std::vector<double>{0, 3, 6, 9}));
  EXPECT_THROW(parse_value_list("w", "10:0:1"), Error);
  EXPECT_THROW(parse_value_list("w", "0:10:0"), Error);
  EXPECT_THROW(parse_value_list("w", "0:10"), Error);
  EXPECT_THROW(parse_value_list("w", "0:1e9:1", 1000), Error);
}

TEST(Text, FormatsListsCompactlyAndRoundTrips) {
  const std::vector<double> v{-80, -78, -76, -74, 0, 5, 45, 46, 47};
  const auto s = format_value_list(v);
  EXPECT_EQ(s, "-80:-74:2,0,5,45:47:1");
  EXPECT_EQ(parse_value_list("x", s), v);
  EXPECT_EQ(format_number(0.05), "0.05");
  EXPECT_EQ(format_number(45), "45");
}

TEST(Text, RoundsAValueToItsUncertainty) {
  // GUM §7.2.6: u to two significant digits, the value to the same decimal place.
  EXPECT_EQ(format_measured(0.3454308, 0.0137220), "0.345 ± 0.014");
  EXPECT_EQ(format_measured(-0.104204, 0.020922), "-0.104 ± 0.021");
  EXPECT_EQ(format_measured(1.0, 0.0996), "1.00 ± 0.10");  // u rounds up to a new digit
  EXPECT_EQ(format_measured(1234.5, 56.2), "1235 ± 56");
  EXPECT_EQ(format_measured(123456, 5612), "123500 ± 5600");
  // A tiny relative u keeps a readable exponent instead of nine decimals.
  EXPECT_EQ(format_measured(0.02, 9.3e-07), "(2.000000 ± 0.000093)e-2");
  EXPECT_EQ(format_measured(0.5, 0), "0.5");
}

TEST(Text, SuggestsNearMatches) {
  const std::vector<std::string> drivers{"modbus", "mock", "scpi-serial", "scpi-tcp", "scpi-usbtmc"};
  EXPECT_EQ(near_matches("mokc", drivers), std::vector<std::string>{"mock"});
  EXPECT_EQ(did_you_mean("mokc", drivers), " (did you mean 'mock'?)");
  EXPECT_EQ(did_you_mean("scpi-tpc", drivers), " (did you mean 'scpi-tcp'?)");
  EXPECT_EQ(did_you_mean("scpi", drivers), " (did you mean 'scpi-serial', 'scpi-tcp' or 'scpi-usbtmc'?)");
  EXPECT_EQ(did_you_mean("xyz", drivers), "");
  EXPECT_EQ(did_you_mean("mock", drivers), "");
}

}  // namespace
}  // namespace gonio::text
