// The Modbus motion driver against the AZ simulator over real TCP loopback sockets: moves,
// readback, homing, stop from another thread, alarms, timeouts, dropped links and
// reconnection with back-off, following error, and limits that move nothing.
#include <atomic>
#include <cmath>
#include <thread>

#include <gtest/gtest.h>

#include "gonio/sim/devsim/modbus_sim.hpp"
#include "gonio/drivers/modbus/link.hpp"
#include "gonio/drivers/modbus/modbus_motion.hpp"
#include "motion_test_util.hpp"

using namespace motion_test;
using gonio::Errc;
using gonio::drivers::Axis;
using gonio::drivers::MotionController;
namespace devsim = gonio::drivers::devsim;
namespace mb = gonio::drivers::modbus;

namespace {

class MotionTcp : public ::testing::Test {
 protected:
  void start(json unit1 = json::object(), json unit2 = json::object(), double min_sep = 10) {
    sim_ = std::make_unique<devsim::ModbusSim>(
        devsim::ModbusSimConfig::from_json(sim_config(true, false, unit1, unit2)));
    sim_->start();
    config_ = driver_config(tcp_link(sim_->tcp_port()));
    motion_ = guarded_motion(config_, min_sep);
  }
  void SetUp() override { start(); }

  std::unique_ptr<devsim::ModbusSim> sim_;
  json config_;
  std::unique_ptr<MotionController> motion_;
};

}  // namespace

TEST_F(MotionTcp, MovesAndReadsBack) {
  EXPECT_EQ(motion_->axes(), (std::vector<Axis>{Axis::incidence, Axis::receive}));
  const auto before = motion_->status(Axis::incidence, 1s);
  EXPECT_TRUE(before.ready);
  EXPECT_TRUE(before.in_position);
  EXPECT_FALSE(before.alarm);

  motion_->move(Axis::incidence, 12.5, 5s);
  EXPECT_EQ(sim_->axis(1).command, 1250);
  EXPECT_EQ(sim_->axis(1).feedback, 1250);
  EXPECT_FALSE(sim_->axis(1).moving);
  EXPECT_DOUBLE_EQ(motion_->position(Axis::incidence, 1s), 12.5);
  const auto s = motion_->status(Axis::incidence, 1s);
  EXPECT_TRUE(s.ready && s.in_position && !s.moving && !s.busy);
  EXPECT_DOUBLE_EQ(s.command_deg, 12.5);

  motion_->move(Axis::receive, 33.33, 5s);
  EXPECT_EQ(sim_->axis(2).command, 3333);
  EXPECT_DOUBLE_EQ(motion_->position(Axis::receive, 1s), 33.33);
  EXPECT_EQ(sim_->axis(1).moves, 1);
  EXPECT_EQ(sim_->axis(2).moves, 1);
}

TEST_F(MotionTcp, MotionTakesTimeAndIsSeenMoving) {
  std::atomic<bool> saw_moving{false};
  std::thread watcher([&] { saw_moving = wait_until([&] { return sim_->axis(1).moving; }, 3s); });
  motion_->move(Axis::incidence, 80, 5s);  // 80° at 200°/s: about 0.45 s
  watcher.join();
  EXPECT_TRUE(saw_moving);
  EXPECT_EQ(sim_->axis(1).feedback, 8000);
}

TEST_F(MotionTcp, HomesToTheHomePosition) {
  motion_->move(Axis::incidence, 7, 5s);
  EXPECT_FALSE(motion_->status(Axis::incidence, 1s).home_end);
  motion_->home(Axis::incidence, 5s);
  const auto s = motion_->status(Axis::incidence, 1s);
  EXPECT_TRUE(s.home_end);
  EXPECT_DOUBLE_EQ(s.position_deg, 0);
  EXPECT_TRUE(sim_->axis(1).home_end);
}

TEST_F(MotionTcp, StopFromAnotherThreadInterruptsAMove) {
  // A slow axis (85° at 20°/s), so that the stop surely lands mid-move.
  auto cfg = config_;
  cfg["axes"]["incidence"]["speed_deg_s"] = 20;
  motion_ = guarded_motion(cfg);
  std::optional<gonio::Error> failure;
  std::thread mover([&] { failure = error_of([&] { motion_->move(Axis::incidence, 85, 10s); }); });
  ASSERT_TRUE(wait_until([&] { return sim_->axis(1).moving && sim_->axis(1).command > 100; }));
  motion_->stop(2s);
  mover.join();
  ASSERT_TRUE(failure);
  EXPECT_EQ(failure->code(), Errc::invalid_state) << failure->what();
  EXPECT_TRUE(mentions(*failure, "stop"));
  const auto at = sim_->axis(1);
  EXPECT_FALSE(at.moving);
  EXPECT_LT(at.command, 8500);
  EXPECT_GT(at.command, 100);
  // STOP was released: the axis takes the next move.
  EXPECT_TRUE(motion_->status(Axis::incidence, 1s).ready);
  motion_->move(Axis::incidence, 3, 5s);
  EXPECT_EQ(sim_->axis(1).command, 300);
}

TEST_F(MotionTcp, AlarmIsReportedWithItsCodeAndReset) {
  sim_->raise_alarm(1, 0x30);
  const auto s = motion_->status(Axis::incidence, 1s);
  EXPECT_TRUE(s.alarm);
  EXPECT_EQ(s.alarm_code, 0x30u);
  EXPECT_FALSE(s.ready);
  const auto e = error_of([&] { motion_->move(Axis::incidence, 5, 2s); });
  EXPECT_EQ(e.code(), Errc::device_alarm);
  EXPECT_TRUE(mentions(e, "0x30")) << e.what();
  EXPECT_EQ(sim_->axis(1).moves, 0);
  motion_->reset_alarm(Axis::incidence, 2s);
  EXPECT_FALSE(motion_->status(Axis::incidence, 1s).alarm);
  motion_->move(Axis::incidence, 5, 5s);
  EXPECT_EQ(sim_->axis(1).command, 500);
}

TEST_F(MotionTcp, ScriptedAlarmDuringTheSecondMove) {
  start(json{{"alarm_at_move", {{"move", 2}, {"code", 0x42}, {"fraction", 0.5}}}});
  motion_->move(Axis::incidence, 10, 5s);
  const auto e = error_of([&] { motion_->move(Axis::incidence, 30, 5s); });
  EXPECT_EQ(e.code(), Errc::device_alarm);
  EXPECT_TRUE(mentions(e, "0x42")) << e.what();
  EXPECT_NEAR(motion_->position(Axis::incidence, 1s), 20, 0.25);  // 1 ms model steps
  motion_->reset_alarm(Axis::incidence, 2s);
  motion_->move(Axis::incidence, 30, 5s);
  EXPECT_DOUBLE_EQ(motion_->position(Axis::incidence, 1s), 30);
}

TEST_F(MotionTcp, TimeoutWhenTheDeviceStopsAnswering) {
  motion_->status(Axis::incidence, 1s);
  sim_->set_mute(true);
  const auto e = error_of([&] { motion_->status(Axis::incidence, 2s); });
  EXPECT_EQ(e.code(), Errc::timeout) << e.what();
  const auto m = error_of([&] { motion_->move(Axis::incidence, 5, 1s); });
  EXPECT_EQ(m.code(), Errc::timeout) << m.what();
  sim_->set_mute(false);
  EXPECT_TRUE(motion_->status(Axis::incidence, 2s).ready);
}

TEST_F(MotionTcp, UnknownUnitGetsNoAnswer) {
  auto cfg = config_;
  cfg["axes"]["receive"]["unit"] = 9;
  auto m = guarded_motion(cfg);
  EXPECT_EQ(error_of([&] { m->status(Axis::receive, 1s); }).code(), Errc::timeout);
  EXPECT_TRUE(m->status(Axis::incidence, 1s).ready);  // the link itself is fine
}

TEST_F(MotionTcp, ReconnectsAfterTheLinkDrops) {
  motion_->move(Axis::incidence, 4, 5s);
  sim_->drop_connections();
  // The next call notices the dropped link, re-opens it and succeeds.
  EXPECT_DOUBLE_EQ(motion_->position(Axis::incidence, 2s), 4);

  // Peer gone for good: disconnected once the deadline is reached.
  sim_->set_offline(true);
  const auto e = error_of([&] { motion_->position(Axis::incidence, 300ms); });
  EXPECT_EQ(e.code(), Errc::disconnected) << e.what();

  // Back while a call is still trying: that call succeeds.
  std::thread back([&] {
    std::this_thread::sleep_for(300ms);
    sim_->set_offline(false);
  });
  EXPECT_DOUBLE_EQ(motion_->position(Axis::incidence, 5s), 4);
  back.join();
}

TEST_F(MotionTcp, LinkBacksOffBetweenAttempts) {
  sim_->set_offline(true);
  mb::LinkConfig lc;
  lc.name = "t";
  lc.host = "127.0.0.1";
  lc.port = sim_->tcp_port();
  mb::LinkTiming t;
  t.backoff_initial = 25ms;
  t.backoff_max = 200ms;
  mb::ModbusLink link(lc, t);
  const auto e = error_of([&] { link.read(1, 0x7F, 1, mb::Clock::now() + 500ms); });
  EXPECT_EQ(e.code(), Errc::disconnected);
  // Attempts at about 0, 25, 75, 175, 375 ms (doubling up to 200): a handful, not a
  // busy loop; and at least one retry.
  const auto attempts = link.connect_attempts();
  EXPECT_GE(attempts, 2u);
  EXPECT_LE(attempts, 8u);
  // The back-off persists across calls: a call whose deadline ends before the next
  // attempt fails at once without trying.
  const auto quick = error_of([&] { link.read(1, 0x7F, 1, mb::Clock::now() + 5ms); });
  EXPECT_EQ(quick.code(), Errc::disconnected);
  EXPECT_EQ(link.connect_attempts(), attempts);
  EXPECT_EQ(link.connects(), 0u);
  sim_->set_offline(false);
  EXPECT_EQ(link.read(1, 0x7F, 1, mb::Clock::now() + 2s).size(), 1u);
  EXPECT_EQ(link.connects(), 1u);
}

TEST_F(MotionTcp, FollowingErrorWhenTheMotorStalls) {
  start(json{{"stall_at_move", {{"move", 1}, {"fraction", 0.5}}}});
  const auto e = error_of([&] { motion_->move(Axis::incidence, 20, 5s); });
  EXPECT_EQ(e.code(), Errc::device_alarm) << e.what();
  EXPECT_TRUE(mentions(e, "following error")) << e.what();
  EXPECT_NEAR(motion_->position(Axis::incidence, 1s), 10, 0.02);
}

TEST_F(MotionTcp, LimitViolationsMoveNothing) {
  motion_->move(Axis::incidence, 45, 5s);
  const auto before = sim_->requests();

  // Soft limits: not a single request.
  const auto soft = error_of([&] { motion_->move(Axis::incidence, 95, 1s); });
  EXPECT_EQ(soft.code(), Errc::limit_violation);
  EXPECT_EQ(soft.field(), "incidence");
  EXPECT_TRUE(mentions(soft, "95")) << soft.what();
  EXPECT_TRUE(mentions(soft, "90")) << soft.what();
  EXPECT_EQ(sim_->requests(), before);

  // The arm guard reads both arm positions back, and writes nothing.

  const auto arms = error_of([&] { motion_->move(Axis::receive, -40, 1s); });  // 5° apart
  EXPECT_EQ(arms.code(), Errc::limit_violation);
  EXPECT_EQ(arms.field(), "receive");
  EXPECT_TRUE(mentions(arms, "-40")) << arms.what();
  EXPECT_TRUE(mentions(arms, "10°")) << arms.what();

  const auto sweep = error_of([&] { motion_->move(Axis::receive, -80, 1s); });  // passes −45°
  EXPECT_EQ(sweep.code(), Errc::limit_violation);
  EXPECT_EQ(sim_->requests(), before + 4);  // two position reads per refused arm move
  EXPECT_EQ(sim_->axis(2).moves, 0);
  EXPECT_EQ(sim_->axis(2).command, 30 * kStepsPerDegree);
}

TEST_F(MotionTcp, NotReadyIsBusy) {
  // Put the axis in FREE (de-energised) with a raw write, as a technician's panel might.
  mb::LinkConfig lc;
  lc.name = "t";
  lc.port = sim_->tcp_port();
  mb::ModbusLink link(lc, {});
  link.write(1, 0x7D, std::array<std::uint16_t, 1>{0x0040}, mb::Clock::now() + 1s);
  const auto e = error_of([&] { motion_->move(Axis::incidence, 5, 1s); });
  EXPECT_EQ(e.code(), Errc::busy) << e.what();
  link.write(1, 0x7D, std::array<std::uint16_t, 1>{0}, mb::Clock::now() + 1s);
  motion_->move(Axis::incidence, 5, 5s);
}

TEST_F(MotionTcp, RefusedWritesAndCorruptRepliesAreProtocolErrors) {
  mb::LinkConfig lc;
  lc.name = "t";
  lc.port = sim_->tcp_port();
  mb::ModbusLink link(lc, {});
  // The feedback position is read-only on the device: exception 02.
  const auto refused = error_of([&] {
    link.write(1, 0x120, std::array<std::uint16_t, 2>{0, 1}, mb::Clock::now() + 1s);
  });
  EXPECT_EQ(refused.code(), Errc::protocol_error) << refused.what();
  // One bad reply is retried (retries = 1); a run of them is reported.
  sim_->corrupt_next_replies(1);
  EXPECT_TRUE(motion_->status(Axis::incidence, 2s).ready);
  sim_->corrupt_next_replies(10);
  const auto bad = error_of([&] { motion_->status(Axis::incidence, 2s); });
  EXPECT_EQ(bad.code(), Errc::protocol_error) << bad.what();
  sim_->corrupt_next_replies(0);
}

TEST_F(MotionTcp, AxesItDoesNotDriveAreUnsupported) {
  EXPECT_EQ(error_of([&] { motion_->move(Axis::tilt, 1, 1s); }).code(), Errc::unsupported);
  EXPECT_FALSE(motion_->has_axis(Axis::rotation));
}
