// SCPI reply parsing: numbers (NR1/NR2/NR3, SCPI infinity and NaN), lists, booleans, error
// queue entries, *IDN? — and that malformed replies are protocol errors.
#include <cmath>

#include <gtest/gtest.h>

#include "gonio/drivers/scpi/scpi.hpp"
#include "gonio/proto/error.hpp"

namespace scpi = gonio::drivers::scpi;
using gonio::Errc;
using gonio::Error;

namespace {

Errc code_of(auto&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.code();
  }
  return Errc::internal;
}

}  // namespace

TEST(ScpiReply, ParsesDecimalForms) {
  EXPECT_DOUBLE_EQ(scpi::parse_number("42"), 42);
  EXPECT_DOUBLE_EQ(scpi::parse_number("+42\r\n"), 42);
  EXPECT_DOUBLE_EQ(scpi::parse_number("-0.125"), -0.125);
  EXPECT_DOUBLE_EQ(scpi::parse_number(" 1.5E-03 "), 1.5e-3);
  EXPECT_DOUBLE_EQ(scpi::parse_number("2.5e+2\n"), 250);
}

TEST(ScpiReply, InfinityAndNaNEncodings) {
  EXPECT_TRUE(std::isinf(scpi::parse_number("9.9E37")));
  EXPECT_GT(scpi::parse_number("9.9E37"), 0);
  EXPECT_LT(scpi::parse_number("-9.9E37"), 0);
  EXPECT_TRUE(std::isnan(scpi::parse_number("9.91E37")));
}

TEST(ScpiReply, RejectsNonNumbers) {
  for (const char* bad : {"", "abc", "1,2", "0x10", "nan", "inf", "1.0V", "1e999", "--1", "\x01"})
    EXPECT_EQ(code_of([&] { scpi::parse_number(bad); }), Errc::protocol_error) << bad;
}

TEST(ScpiReply, ParsesLists) {
  const auto v = scpi::parse_numbers("1,2.5,-3E2\n");
  ASSERT_EQ(v.size(), 3u);
  EXPECT_DOUBLE_EQ(v[2], -300);
  EXPECT_EQ(code_of([] { scpi::parse_numbers("1,,2"); }), Errc::protocol_error);
  EXPECT_EQ(code_of([] { scpi::parse_numbers("1,2,"); }), Errc::protocol_error);
  EXPECT_EQ(code_of([] { scpi::parse_numbers("1,2,3", "x", 2); }), Errc::protocol_error);
}

TEST(ScpiReply, Booleans) {
  EXPECT_TRUE(scpi::parse_bool("1"));
  EXPECT_FALSE(scpi::parse_bool("OFF\n"));
  EXPECT_EQ(code_of([] { scpi::parse_bool("2"); }), Errc::protocol_error);
}

TEST(ScpiReply, ErrorQueueEntries) {
  EXPECT_EQ(scpi::parse_error_entry("0,\"No error\"\n"), (scpi::ErrorEntry{0, "No error"}));
  EXPECT_EQ(scpi::parse_error_entry("-113,\"Undefined header\""),
            (scpi::ErrorEntry{-113, "Undefined header"}));
  EXPECT_EQ(scpi::parse_error_entry("+201,\"say \"\"hi\"\"\""), (scpi::ErrorEntry{201, "say \"hi\""}));
  // Bytes that are not printable ASCII end up in logs and JSON replies: escaped.
  EXPECT_EQ(scpi::parse_error_entry("-222,\"Temp 40\xb0\x01\""), (scpi::ErrorEntry{-222, "Temp 40\\xb0\\x01"}));
  for (const char* bad : {"", "-113", "x,\"a\"", "-113,a", "-113,\"a\"b\""})
    EXPECT_EQ(code_of([&] { scpi::parse_error_entry(bad); }), Errc::protocol_error) << bad;
}

TEST(ScpiReply, Identity) {
  const auto id = scpi::parse_identity("Thorlabs,PM100D,P0001234,2.4.0\n");
  EXPECT_EQ(id.manufacturer, "Thorlabs");
  EXPECT_EQ(id.model, "PM100D");
  EXPECT_EQ(id.serial, "P0001234");
  EXPECT_EQ(id.firmware, "2.4.0");
  EXPECT_EQ(code_of([] { scpi::parse_identity("a,b,c"); }), Errc::protocol_error);
  EXPECT_EQ(code_of([] { scpi::parse_identity(",b,c,d"); }), Errc::protocol_error);
  EXPECT_EQ(code_of([] { scpi::parse_identity(std::string("a,b\x07,c,d")); }), Errc::protocol_error);
}

TEST(ScpiReply, PresetNames) {
  EXPECT_EQ(gonio::parse_enum<scpi::Preset>("pm100", "preset"), scpi::Preset::pm100);
  EXPECT_EQ(gonio::to_text(scpi::Preset::gonio), "gonio");
  EXPECT_EQ(code_of([] { gonio::parse_enum<scpi::Preset>("keithley", "preset"); }), Errc::invalid_argument);
}
