// Modbus register map: 32-bit encoding (upper word first, two's complement), steps <->
// degrees, the AZ preset, status and input words, strict JSON reading and validation.
#include <cstdint>
#include <limits>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/drivers/modbus/register_map.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/test/error_of.hpp"

namespace mb = gonio::drivers::modbus;
using gonio::Errc;
using gonio::Error;
using gonio::test::error_of;
using nlohmann::json;

TEST(MotionRegisterEncoding, UpperWordFirst) {
  EXPECT_EQ(mb::encode_u32(0x12345678u, mb::WordOrder::high_first),
            (std::array<std::uint16_t, 2>{0x1234, 0x5678}));
  EXPECT_EQ(mb::encode_u32(0x12345678u, mb::WordOrder::low_first),
            (std::array<std::uint16_t, 2>{0x5678, 0x1234}));
  EXPECT_EQ(mb::decode_u32(0x1234, 0x5678, mb::WordOrder::high_first), 0x12345678u);
  EXPECT_EQ(mb::decode_u32(0x5678, 0x1234, mb::WordOrder::low_first), 0x12345678u);
}

TEST(MotionRegisterEncoding, NegativePositionsAreTwosComplement) {
  // Oriental Motor's own example: −1000 steps is FFFF FC18h (upper, lower).
  EXPECT_EQ(mb::encode_i32(-1000, mb::WordOrder::high_first),
            (std::array<std::uint16_t, 2>{0xFFFF, 0xFC18}));
  EXPECT_EQ(mb::decode_i32(0xFFFF, 0xFC18, mb::WordOrder::high_first), -1000);
  for (const std::int32_t v : {0, 1, -1, 65535, 65536, -65536, std::numeric_limits<std::int32_t>::min(),
                               std::numeric_limits<std::int32_t>::max()}) {
    for (const auto order : {mb::WordOrder::high_first, mb::WordOrder::low_first}) {
      const auto w = mb::encode_i32(v, order);
      EXPECT_EQ(mb::decode_i32(w[0], w[1], order), v) << v;
    }
  }
}

TEST(MotionRegisterEncoding, StepsAndDegrees) {
  mb::AxisScale s{100, 0};
  EXPECT_EQ(s.to_steps(12.5, "x"), 1250);
  EXPECT_EQ(s.to_steps(-0.004, "x"), 0);   // nearest step
  EXPECT_EQ(s.to_steps(-0.006, "x"), -1);
  EXPECT_DOUBLE_EQ(s.to_degrees(-1250), -12.5);
  mb::AxisScale rev{-200, 10};  // reversed direction, zero at 10°
  EXPECT_EQ(rev.to_steps(12, "x"), -400);
  EXPECT_DOUBLE_EQ(rev.to_degrees(-400), 12);
  EXPECT_DOUBLE_EQ(rev.to_step_rate(5), 1000);
  const Error e = error_of([&] { mb::AxisScale{1e6, 0}.to_steps(3000, "axes.tilt"); });
  EXPECT_EQ(e.code(), Errc::out_of_range);
  EXPECT_EQ(e.field(), "axes.tilt");
  EXPECT_NE(std::string(e.what()).find("3000"), std::string::npos);
}

TEST(MotionRegisterMap, AzPresetAddresses) {
  const auto m = mb::RegisterMap::preset("az");
  EXPECT_EQ(m.data_no, 0x0058);
  EXPECT_EQ(m.operation_type, 0x005A);
  EXPECT_EQ(m.position, 0x005C);
  EXPECT_EQ(m.speed, 0x005E);
  EXPECT_EQ(m.rate, 0x0060);
  EXPECT_EQ(m.stop_rate, 0x0062);
  EXPECT_EQ(m.current, 0x0064);
  EXPECT_EQ(m.trigger, 0x0066);
  EXPECT_EQ(m.input_command, 0x007D);
  EXPECT_EQ(m.output_status, 0x007F);
  EXPECT_EQ(m.alarm_code, 0x0080);
  EXPECT_EQ(m.feedback_position, 0x0120);
  EXPECT_EQ(m.command_position, 0x0122);
  EXPECT_TRUE(m.direct_block());
  EXPECT_EQ(m.word_order, mb::WordOrder::high_first);
  EXPECT_EQ(error_of([] { mb::RegisterMap::preset("ezsii"); }).code(), Errc::not_found);
}

TEST(MotionRegisterMap, StatusAndInputWords) {
  const auto m = mb::RegisterMap::preset("az");
  EXPECT_EQ(mb::input_word(m.input.start), 0x0008);
  EXPECT_EQ(mb::input_word(m.input.zhome), 0x0010);
  EXPECT_EQ(mb::input_word(m.input.stop), 0x0020);
  EXPECT_EQ(mb::input_word(m.input.free), 0x0040);
  EXPECT_EQ(mb::input_word(m.input.alarm_reset), 0x0080);
  EXPECT_EQ(mb::input_word(-1), 0);

  const auto s = mb::decode_status(0x0020 | 0x4000, m.output);  // READY, IN-POS
  EXPECT_TRUE(s.ready);
  EXPECT_TRUE(s.in_position);
  EXPECT_FALSE(s.moving || s.busy || s.alarm || s.home_end);
  const auto moving = mb::decode_status(0x2000 | 0x0100, m.output);  // MOVE, SYS-BSY
  EXPECT_TRUE(moving.moving);
  EXPECT_TRUE(moving.busy);
  EXPECT_FALSE(moving.ready);
  EXPECT_TRUE(mb::decode_status(0x0080, m.output).alarm);
  EXPECT_TRUE(mb::decode_status(0x0010, m.output).home_end);
  // Every combination survives encode -> decode.
  for (unsigned w = 0; w < 64; ++w) {
    mb::StatusBits b{(w & 1) != 0, (w & 2) != 0, (w & 4) != 0, (w & 8) != 0, (w & 16) != 0, (w & 32) != 0};
    EXPECT_EQ(mb::decode_status(mb::encode_status(b, m.output), m.output), b);
  }
  // A map without a home-end signal never reports it.
  auto no_home = m.output;
  no_home.home_end = -1;
  EXPECT_FALSE(mb::decode_status(0xFFFF, no_home).home_end);
}

TEST(MotionRegisterMap, JsonOverridesPreset) {
  const auto m = mb::RegisterMap::from_json(
      json{{"preset", "az"},
           {"registers", {{"feedback_position", "0x00CC"}, {"command_position", 198}}},
           {"output_bits", {{"home_end", -1}}},
           {"word_order", "low_first"}},
      "register_map");
  EXPECT_EQ(m.feedback_position, 0x00CC);
  EXPECT_EQ(m.command_position, 198);
  EXPECT_EQ(m.output.home_end, -1);
  EXPECT_EQ(m.word_order, mb::WordOrder::low_first);
  EXPECT_EQ(m.position, 0x005C);  // untouched
  // Round trip through to_json.
  EXPECT_EQ(mb::RegisterMap::from_json(m.to_json(), "m"), m);
  EXPECT_EQ(mb::RegisterMap::from_json(json::object(), "m"), mb::RegisterMap::preset("az"));
}

TEST(MotionRegisterMap, RejectsUnknownKeysAndBadValues) {
  const auto field_of = [](const json& j) {
    return error_of([&] { mb::RegisterMap::from_json(j, "register_map"); }).field();
  };
  EXPECT_EQ(field_of(json{{"registerz", json::object()}}), "register_map.registerz");
  EXPECT_EQ(field_of(json{{"registers", {{"speeed", 1}}}}), "register_map.registers.speeed");
  EXPECT_EQ(field_of(json{{"registers", {{"speed", 70000}}}}), "register_map.registers.speed");
  EXPECT_EQ(field_of(json{{"registers", {{"speed", "0xZZ"}}}}), "register_map.registers.speed");
  EXPECT_EQ(field_of(json{{"registers", {{"speed", -1}}}}), "register_map.registers.speed");
  EXPECT_EQ(field_of(json{{"registers", {{"speed", 1.5}}}}), "register_map.registers.speed");
  EXPECT_EQ(field_of(json{{"input_bits", {{"stop", 16}}}}), "register_map.input_bits.stop");
  EXPECT_EQ(field_of(json{{"input_bits", {{"stop", -1}}}}), "register_map.input_bits.stop");
  EXPECT_EQ(field_of(json{{"word_order", "middle"}}), "register_map.word_order");
  EXPECT_EQ(field_of(json{{"trigger_value", 0}}), "register_map.trigger_value");
  EXPECT_EQ(field_of(json{{"rate_unit_hz_per_s", 0}}), "register_map.rate_unit_hz_per_s");
  EXPECT_EQ(field_of(json{{"preset", "nope"}}), "register_map.preset");
  EXPECT_EQ(field_of(json::array()), "register_map");

  const Error range = error_of([] {
    mb::RegisterMap::from_json(json{{"output_bits", {{"ready", 99}}}}, "map");
  });
  EXPECT_EQ(range.code(), Errc::out_of_range);
  EXPECT_NE(std::string(range.what()).find("99"), std::string::npos);
  EXPECT_NE(std::string(range.what()).find("15"), std::string::npos);
}

TEST(MotionRegisterMap, RejectsOverlapsAndSharedBits) {
  // The position pair 0x005C..5D would cover the speed's upper word.
  const Error overlap = error_of([] {
    mb::RegisterMap::from_json(json{{"registers", {{"speed", "0x005D"}}}}, "m");
  });
  EXPECT_EQ(overlap.code(), Errc::invalid_argument);
  EXPECT_NE(std::string(overlap.what()).find("overlap"), std::string::npos);
  // A 32-bit value may not start at the last address.
  EXPECT_EQ(error_of([] { mb::RegisterMap::from_json(json{{"registers", {{"alarm_code", 65535}}}}, "m"); })
                .field(),
            "m.registers.alarm_code");
  const Error shared = error_of([] {
    mb::RegisterMap::from_json(json{{"output_bits", {{"busy", 5}}}}, "m");  // READY is bit 5
  });
  EXPECT_EQ(shared.field(), "m.output_bits.busy");  // the later one is the clash
  EXPECT_NE(std::string(shared.what()).find("bit 5"), std::string::npos);
}

TEST(MotionRegisterMap, DirectBlockOnlyWhenContiguous) {
  auto m = mb::RegisterMap::preset("az");
  m.trigger = 0x0070;
  EXPECT_FALSE(m.direct_block());
  m = mb::RegisterMap::preset("az");
  std::swap(m.speed, m.rate);
  EXPECT_FALSE(m.direct_block());
}
