// The register behaviour of one simulated AZ unit, without a socket: what writes of the
// direct data, the trigger and the input command do to the axis, and what the status and
// monitor registers show.
#include <array>
#include <cstdint>
#include <vector>

#include <gtest/gtest.h>

#include "gonio/proto/error.hpp"
#include "gonio/sim/devsim/modbus_sim.hpp"

namespace devsim = gonio::drivers::devsim;
namespace mb = gonio::drivers::modbus;
using devsim::SimUnit;

namespace {

const mb::RegisterMap kMap = mb::RegisterMap::preset("az");

SimUnit make_unit(bool instant = false) {
  devsim::SimAxisConfig c;
  c.unit = 3;
  c.home_position_steps = 0;
  return SimUnit(c, kMap, instant);
}

// The 16-register direct-data block: data no., operation type, position, speed, rate,
// stop rate, current, trigger.
std::vector<std::uint16_t> direct_block(std::int32_t target, std::int32_t op = 1,
                                        std::int32_t trigger = 1) {
  std::vector<std::uint16_t> out;
  for (const std::int32_t v : {0, op, target, 10000, 100000, 100000, 1000, trigger}) {
    const auto w = mb::encode_i32(v, kMap.word_order);
    out.insert(out.end(), w.begin(), w.end());
  }
  return out;
}

std::int32_t read_i32(SimUnit& u, std::uint16_t addr) {
  const auto r = u.read(addr, 2);
  return mb::decode_i32(r[0], r[1], kMap.word_order);
}

mb::StatusBits status(SimUnit& u) { return mb::decode_status(u.read(kMap.output_status, 1)[0], kMap.output); }

void write_inputs(SimUnit& u, std::uint16_t word) {
  const std::array<std::uint16_t, 1> w{word};
  u.write(kMap.input_command, w);
}

}  // namespace

TEST(MotionSimUnit, TriggerStartsTheDirectDataMoveAndReadsBackZero) {
  SimUnit u = make_unit();
  ASSERT_TRUE(status(u).ready);
  u.write(kMap.data_no, direct_block(-2500));
  EXPECT_EQ(read_i32(u, kMap.trigger), 0);
  const auto moving = status(u);
  EXPECT_TRUE(moving.moving);
  EXPECT_TRUE(moving.busy);
  EXPECT_FALSE(moving.ready);
  EXPECT_FALSE(moving.in_position);
  for (int i = 0; i < 1000 && u.axis().moving(); ++i) u.advance(0.01);
  EXPECT_EQ(read_i32(u, kMap.command_position), -2500);
  EXPECT_EQ(read_i32(u, kMap.feedback_position), -2500);
  const auto rest = status(u);
  EXPECT_TRUE(rest.ready);
  EXPECT_TRUE(rest.in_position);
  EXPECT_FALSE(rest.moving);
  EXPECT_EQ(u.axis().moves_started(), 1);
}

TEST(MotionSimUnit, DataWithoutTheTriggerDoesNotMove) {
  SimUnit u = make_unit(true);
  u.write(kMap.data_no, direct_block(1000, 1, 0));
  EXPECT_EQ(u.axis().moves_started(), 0);
  EXPECT_EQ(read_i32(u, kMap.command_position), 0);
  // The trigger alone, later, takes the data written before.
  const auto trig = mb::encode_i32(1, kMap.word_order);
  u.write(kMap.trigger, trig);
  EXPECT_EQ(read_i32(u, kMap.command_position), 1000);
}

TEST(MotionSimUnit, StatusAndMonitorRegistersAreReadOnly) {
  SimUnit u = make_unit();
  EXPECT_TRUE(u.read_only(kMap.output_status, 1));
  EXPECT_TRUE(u.read_only(kMap.feedback_position + 1, 1));
  EXPECT_TRUE(u.read_only(kMap.alarm_code - 1, 2));
  EXPECT_FALSE(u.read_only(kMap.input_command, 1));
  EXPECT_FALSE(u.read_only(kMap.data_no, 16));
  const std::array<std::uint16_t, 2> w{0x1234, 0x5678};
  try {
    u.write(kMap.feedback_position, w);
    FAIL() << "a write to the feedback position was accepted";
  } catch (const gonio::Error& e) {
    EXPECT_EQ(e.code(), gonio::Errc::invalid_argument);
    EXPECT_EQ(e.field(), "address");
  }
  EXPECT_EQ(read_i32(u, kMap.feedback_position), 0);
  EXPECT_THROW(u.read(0xFFFF, 4), gonio::Error);
  EXPECT_THROW(u.write(-1, w), gonio::Error);
}

TEST(MotionSimUnit, InputCommandLevelsAndRisingEdges) {
  SimUnit u = make_unit(true);
  // STOP is a level: not ready while on, and a trigger is ignored.
  write_inputs(u, mb::input_word(kMap.input.stop));
  EXPECT_FALSE(status(u).ready);
  u.write(kMap.data_no, direct_block(500));
  EXPECT_EQ(u.axis().moves_started(), 0);
  write_inputs(u, 0);
  EXPECT_TRUE(status(u).ready);
  // ZHOME homes on its rising edge: HOME-END afterwards.
  u.write(kMap.data_no, direct_block(500));
  ASSERT_EQ(read_i32(u, kMap.command_position), 500);
  write_inputs(u, mb::input_word(kMap.input.zhome));
  EXPECT_TRUE(status(u).home_end);
  EXPECT_EQ(read_i32(u, kMap.command_position), 0);
  // Holding ZHOME on is no new edge; after a move, HOME-END is gone and stays gone.
  write_inputs(u, mb::input_word(kMap.input.zhome));
  u.write(kMap.data_no, direct_block(100));
  write_inputs(u, mb::input_word(kMap.input.zhome));
  EXPECT_FALSE(status(u).home_end);
  write_inputs(u, 0);
  // START on its rising edge runs the direct data in the registers.
  write_inputs(u, mb::input_word(kMap.input.start));
  EXPECT_EQ(u.axis().moves_started(), 3);
}

TEST(MotionSimUnit, AlarmShowsInTheRegistersUntilReset) {
  SimUnit u = make_unit(true);
  u.write(kMap.data_no, direct_block(1000, /*op=*/7));  // not absolute positioning
  EXPECT_EQ(read_i32(u, kMap.alarm_code), 0x70);
  auto s = status(u);
  EXPECT_TRUE(s.alarm);
  EXPECT_FALSE(s.ready);
  write_inputs(u, mb::input_word(kMap.input.alarm_reset));
  EXPECT_EQ(read_i32(u, kMap.alarm_code), 0);
  s = status(u);
  EXPECT_FALSE(s.alarm);
  EXPECT_TRUE(s.ready);
  u.raise_alarm(0x30);
  EXPECT_EQ(read_i32(u, kMap.alarm_code), 0x30);
}
