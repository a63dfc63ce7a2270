// The Modbus motion driver over RTU on a real pty (115200 8E1) against the AZ simulator:
// two units on one line, moves, homing, stop from another thread, timeouts, bad CRCs,
// limits that move nothing, and an absent serial device.
#include <atomic>
#include <thread>

#include <gtest/gtest.h>

#include "gonio/sim/devsim/modbus_sim.hpp"
#include "gonio/drivers/modbus/modbus_motion.hpp"
#include "motion_test_util.hpp"

using namespace motion_test;
using gonio::Errc;
using gonio::drivers::Axis;
using gonio::drivers::MotionController;
namespace devsim = gonio::drivers::devsim;

namespace {

class MotionRtu : public ::testing::Test {
 protected:
  void SetUp() override {
    sim_ = std::make_unique<devsim::ModbusSim>(devsim::ModbusSimConfig::from_json(sim_config(false, true)));
    sim_->start();
    ASSERT_EQ(sim_->rtu_path().rfind("/dev/pts/", 0), 0u) << sim_->rtu_path();
    motion_ = guarded_motion(driver_config(rtu_link(sim_->rtu_path())));
  }

  std::unique_ptr<devsim::ModbusSim> sim_;
  std::unique_ptr<MotionController> motion_;
};

}  // namespace

TEST_F(MotionRtu, TwoUnitsOnOneLine) {
  motion_->move(Axis::incidence, 20.25, 5s);
  motion_->move(Axis::receive, 50, 5s);
  EXPECT_EQ(sim_->axis(1).command, 2025);
  EXPECT_EQ(sim_->axis(2).command, 5000);
  EXPECT_DOUBLE_EQ(motion_->position(Axis::incidence, 1s), 20.25);
  EXPECT_DOUBLE_EQ(motion_->position(Axis::receive, 1s), 50);
  motion_->home(Axis::incidence, 5s);
  EXPECT_DOUBLE_EQ(motion_->position(Axis::incidence, 1s), 0);
  EXPECT_TRUE(motion_->status(Axis::incidence, 1s).home_end);
  EXPECT_FALSE(motion_->status(Axis::receive, 1s).home_end);
}

TEST_F(MotionRtu, StopFromAnotherThread) {
  auto cfg = driver_config(rtu_link(sim_->rtu_path()));
  cfg["axes"]["receive"]["speed_deg_s"] = 20;  // slow: the stop surely lands mid-move
  motion_ = guarded_motion(cfg);
  std::optional<gonio::Error> failure;
  std::thread mover([&] { failure = error_of([&] { motion_->move(Axis::receive, 85, 10s); }); });
  ASSERT_TRUE(wait_until([&] { return sim_->axis(2).moving && sim_->axis(2).command > 3100; }));
  motion_->stop(2s);
  mover.join();
  ASSERT_TRUE(failure);
  EXPECT_EQ(failure->code(), Errc::invalid_state) << failure->what();
  EXPECT_FALSE(sim_->axis(2).moving);
  EXPECT_LT(sim_->axis(2).command, 8500);
  motion_->move(Axis::receive, 40, 5s);
  EXPECT_EQ(sim_->axis(2).command, 4000);
}

TEST_F(MotionRtu, TimeoutWhenMuted) {
  sim_->set_mute(true);
  const auto e = error_of([&] { motion_->position(Axis::incidence, 2s); });
  EXPECT_EQ(e.code(), Errc::timeout) << e.what();
  EXPECT_TRUE(mentions(e, "rtu")) << e.what();
  sim_->set_mute(false);
  EXPECT_DOUBLE_EQ(motion_->position(Axis::incidence, 2s), 0);
}

TEST_F(MotionRtu, BadCrcIsRetriedThenReported) {
  sim_->corrupt_next_replies(1);
  EXPECT_TRUE(motion_->status(Axis::incidence, 2s).ready);
  sim_->corrupt_next_replies(10);
  const auto e = error_of([&] { motion_->status(Axis::incidence, 2s); });
  EXPECT_EQ(e.code(), Errc::protocol_error) << e.what();
  sim_->corrupt_next_replies(0);
  EXPECT_TRUE(motion_->status(Axis::incidence, 2s).ready);
}

TEST_F(MotionRtu, LimitViolationsMoveNothing) {
  const auto before = sim_->requests();
  EXPECT_EQ(error_of([&] { motion_->move(Axis::receive, -91, 1s); }).code(), Errc::limit_violation);
  EXPECT_EQ(sim_->requests(), before);  // soft limits: not a single request
  EXPECT_EQ(error_of([&] { motion_->move(Axis::incidence, -25, 1s); }).code(), Errc::limit_violation);
  EXPECT_EQ(sim_->requests(), before + 2);  // the arm guard read both arm positions back
  EXPECT_EQ(sim_->axis(1).moves, 0);
  EXPECT_EQ(sim_->axis(2).moves, 0);
}

TEST(MotionRtuAbsent, MissingDeviceIsDisconnected) {
  auto m = guarded_motion(driver_config(rtu_link("/dev/gonio-no-such-tty")));
  const auto e = error_of([&] { m->status(Axis::incidence, 300ms); });
  EXPECT_EQ(e.code(), Errc::disconnected) << e.what();
  EXPECT_TRUE(mentions(e, "/dev/gonio-no-such-tty")) << e.what();
}
