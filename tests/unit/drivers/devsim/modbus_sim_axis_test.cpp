// The simulated AZ axis: trapezoidal motion with finite time, status signals, deceleration
// stop, homing, scripted alarm and stall, instant mode. Pure model: simulated time only.
#include <cmath>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/sim/devsim/modbus_sim.hpp"
#include "gonio/proto/error.hpp"

namespace devsim = gonio::drivers::devsim;
using devsim::SimAxis;
using devsim::SimAxisConfig;

namespace {

// Advances in 10 ms ticks until the axis stops; returns the simulated time it took.
double run_to_rest(SimAxis& a, double limit_s = 100) {
  double t = 0;
  while (a.moving() && t < limit_s) {
    a.advance(0.01);
    t += 0.01;
  }
  return t;
}

}  // namespace

TEST(MotionSimAxis, TrapezoidTakesTheKinematicTime) {
  SimAxis a(SimAxisConfig{}, false);
  ASSERT_TRUE(a.ready());
  // 10000 steps at 10000 Hz with 100000 Hz/s ramps: 0.1 s up, 0.9 s cruise, 0.1 s down.
  a.start_move(10000, 10000, 100000, 100000);
  EXPECT_TRUE(a.moving());
  EXPECT_TRUE(a.busy());
  EXPECT_FALSE(a.ready());
  EXPECT_FALSE(a.in_position());
  a.advance(0.1);  // end of the ramp: ½·a·t² = 500 steps
  EXPECT_NEAR(a.command(), 500, 15);
  a.advance(0.5);  // cruising
  EXPECT_NEAR(a.command(), 5500, 20);
  const double rest = run_to_rest(a);
  EXPECT_NEAR(0.6 + rest, 1.1, 0.03);
  EXPECT_EQ(a.command(), 10000);
  EXPECT_EQ(a.feedback(), 10000);
  EXPECT_TRUE(a.in_position());
  EXPECT_TRUE(a.ready());
  EXPECT_EQ(a.moves_started(), 1);
}

TEST(MotionSimAxis, ShortMovesNeverReachFullSpeedAndLandExactly) {
  SimAxis a(SimAxisConfig{}, false);
  a.start_move(-37, 50000, 20000, 20000);  // triangle profile, negative direction
  const double t = run_to_rest(a);
  EXPECT_EQ(a.command(), -37);
  EXPECT_NEAR(t, 2 * std::sqrt(37.0 / 20000), 0.02);  // t = 2·√(d/a)
}

TEST(MotionSimAxis, StopDeceleratesShortOfTheTarget) {
  SimAxis a(SimAxisConfig{}, false);
  a.start_move(100000, 10000, 100000, 50000);
  a.advance(0.5);
  const auto at_stop = a.command();
  a.set_stop(true);
  EXPECT_FALSE(a.ready());
  run_to_rest(a);
  // v = 10000 Hz, deceleration 50000 Hz/s: v²/2d = 1000 steps more.
  EXPECT_NEAR(a.command() - at_stop, 1000, 30);
  EXPECT_LT(a.command(), 100000);
  EXPECT_FALSE(a.ready());  // STOP still on
  a.set_stop(false);
  EXPECT_TRUE(a.ready());
  EXPECT_FALSE(a.home_end());
}

TEST(MotionSimAxis, NotReadyIgnoresMovesAndBadDataRaisesAnAlarm) {
  SimAxis a(SimAxisConfig{}, false);
  a.set_free(true);
  a.start_move(1000, 1000, 1000, 1000);
  EXPECT_FALSE(a.moving());
  a.set_free(false);
  a.start_move(1000, 0, 1000, 1000);
  EXPECT_EQ(a.alarm(), 0x70u);
  EXPECT_FALSE(a.ready());
  a.reset_alarm();
  EXPECT_TRUE(a.ready());
}

TEST(MotionSimAxis, HomingEndsAtHomeWithHomeEnd) {
  SimAxisConfig c;
  c.position_steps = 4000;
  c.home_position_steps = 100;
  SimAxis a(c, false);
  EXPECT_EQ(a.feedback(), 4000);
  a.start_home();
  EXPECT_TRUE(a.moving());
  EXPECT_FALSE(a.home_end());
  run_to_rest(a);
  EXPECT_EQ(a.command(), 100);
  EXPECT_TRUE(a.home_end());
  a.start_move(200, 1000, 10000, 10000);
  EXPECT_FALSE(a.home_end());
}

TEST(MotionSimAxis, ScriptedAlarmStopsPartWay) {
  SimAxisConfig c;
  c.alarm_at_move = devsim::SimFault{2, 0.25, 0x30};
  SimAxis a(c, false);
  a.start_move(1000, 5000, 50000, 50000);
  run_to_rest(a);
  EXPECT_EQ(a.alarm(), 0u);
  a.start_move(5000, 5000, 50000, 50000);  // move 2: alarm at 1000 + 0.25·4000 = 2000
  run_to_rest(a);
  EXPECT_EQ(a.alarm(), 0x30u);
  EXPECT_NEAR(a.command(), 2000, 10);
  EXPECT_FALSE(a.moving());
  EXPECT_FALSE(a.ready());
  a.reset_alarm();
  a.start_move(0, 5000, 50000, 50000);  // move 3 is clean
  run_to_rest(a);
  EXPECT_EQ(a.command(), 0);
  EXPECT_EQ(a.alarm(), 0u);
}

TEST(MotionSimAxis, StallFreezesTheFeedback) {
  SimAxisConfig c;
  c.stall_at_move = devsim::SimFault{1, 0.5, 0};
  SimAxis a(c, false);
  a.start_move(-8000, 20000, 200000, 200000);
  run_to_rest(a);
  EXPECT_EQ(a.command(), -8000);
  EXPECT_EQ(a.feedback(), -4000);
  EXPECT_FALSE(a.in_position());
  // The next move starts from where the motor really is.
  a.start_move(-4000, 20000, 200000, 200000);
  run_to_rest(a);
  EXPECT_EQ(a.feedback(), -4000);
  EXPECT_TRUE(a.in_position());
}

TEST(MotionSimAxis, InstantModeCompletesAtOnce) {
  SimAxisConfig c;
  c.alarm_at_move = devsim::SimFault{2, 0.5, 0x42};
  SimAxis a(c, true);
  a.start_move(123, 1, 1, 1);
  EXPECT_FALSE(a.moving());
  EXPECT_EQ(a.feedback(), 123);
  a.start_move(323, 1, 1, 1);
  EXPECT_EQ(a.alarm(), 0x42u);
  EXPECT_EQ(a.command(), 223);
  a.reset_alarm();
  a.start_home();
  EXPECT_TRUE(a.home_end());
  EXPECT_EQ(a.command(), 0);
}

TEST(MotionSimConfig, StrictJson) {
  using nlohmann::json;
  const auto c = devsim::ModbusSimConfig::from_json(
      json{{"tcp", {{"port", 0}}},
           {"motion", "instant"},
           {"units", {{{"unit", 3}, {"stall_at_move", {{"move", 2}, {"fraction", 0.3}}}}}}});
  EXPECT_EQ(c.tcp_host.value_or(""), "127.0.0.1");
  EXPECT_TRUE(c.instant);
  ASSERT_EQ(c.units.size(), 1u);
  EXPECT_EQ(c.units[0].stall_at_move->move, 2);
  const auto field = [](const json& j) {
    try {
      devsim::ModbusSimConfig::from_json(j);
    } catch (const gonio::Error& e) {
      return e.field();
    }
    return std::string("no error");
  };
  EXPECT_EQ(field(json{{"rtu", true}, {"units", {{{"unit", 1}, {"speed", 1}}}}}), "units[0].speed");
  EXPECT_EQ(field(json{{"rtu", true}, {"units", {{{"unit", 0}}}}}), "units[0].unit");
  EXPECT_EQ(field(json{{"rtu", true}, {"units", {{{"unit", 1}}, {{"unit", 1}}}}}), "units[1].unit");
  EXPECT_EQ(field(json{{"rtu", true}, {"units", json::array()}}), "units");
  EXPECT_EQ(field(json{{"units", {{{"unit", 1}}}}}), "tcp");
  EXPECT_EQ(field(json{{"rtu", true}, {"motion", "warp"}, {"units", {{{"unit", 1}}}}}), "motion");
  EXPECT_EQ(field(json{{"rtu", true},
                       {"units", {{{"unit", 1}, {"alarm_at_move", {{"move", 0}}}}}}}),
            "units[0].alarm_at_move.move");
}
