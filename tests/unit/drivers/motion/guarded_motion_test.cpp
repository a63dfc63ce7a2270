// GuardedMotion and the limits table: a rejected move never reaches the wrapped
// controller; soft limits and the swept-path arm collision are enforced from positions
// read back from it; everything else passes through.
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gonio/drivers/motion/guarded_motion.hpp"
#include "gonio/drivers/motion/limits.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/test/error_of.hpp"

using gonio::Errc;
using gonio::Error;
using gonio::test::error_of;
using gonio::drivers::Axis;
using gonio::drivers::AxisStatus;
using gonio::drivers::GuardedMotion;
using gonio::drivers::MotionCapabilities;
using gonio::drivers::MotionController;
using gonio::drivers::MotionGuard;
using gonio::drivers::MotionLimits;
using gonio::drivers::SoftLimits;
using namespace std::chrono_literals;

namespace {

// Records every call; moves land at once.
class FakeMotion final : public MotionController {
 public:
  explicit FakeMotion(std::vector<Axis> axes) : axes_(std::move(axes)) {
    for (const Axis a : axes_) pos[a] = 0;
  }
  MotionCapabilities capabilities() const override { return {false, true, false}; }
  std::vector<Axis> axes() const override { return axes_; }
  void move(Axis a, double target, std::chrono::milliseconds timeout) override {
    calls.push_back("move " + std::string(gonio::to_text(a)) + " " + std::to_string(static_cast<int>(target)));
    last_timeout = timeout;
    pos[a] = target;
  }
  double position(Axis a, std::chrono::milliseconds) override {
    ++position_reads;
    return pos.at(a);
  }
  AxisStatus status(Axis a, std::chrono::milliseconds) override {
    calls.push_back("status " + std::string(gonio::to_text(a)));
    AxisStatus s;
    s.position_deg = pos.at(a);
    return s;
  }
  void home(Axis a, std::chrono::milliseconds) override {
    calls.push_back("home " + std::string(gonio::to_text(a)));
    pos[a] = home_at.value_or(0);
  }
  std::optional<double> home_position(Axis) const override { return home_at; }
  void reset_alarm(Axis a, std::chrono::milliseconds) override {
    calls.push_back("reset_alarm " + std::string(gonio::to_text(a)));
  }
  void stop(std::chrono::milliseconds) override { calls.push_back("stop"); }

  std::map<Axis, double> pos;
  std::vector<std::string> calls;
  int position_reads = 0;
  std::chrono::milliseconds last_timeout{0};
  std::optional<double> home_at;  // known to the controller, or not

 private:
  std::vector<Axis> axes_;
};

struct Rig {
  FakeMotion* fake;
  std::unique_ptr<GuardedMotion> motion;
};

Rig make(const MotionLimits& limits, double default_sep = 0,
         std::vector<Axis> axes = {Axis::incidence, Axis::receive, Axis::rotation}) {
  auto fake = std::make_unique<FakeMotion>(std::move(axes));
  auto* raw = fake.get();
  return {raw, std::make_unique<GuardedMotion>(std::move(fake), limits.guard(default_sep))};
}

bool contains(const Error& e, const std::string& s) {
  return std::string(e.what()).find(s) != std::string::npos;
}

}  // namespace

TEST(MotionLimits, TableGivesEveryAxisItsLimitsAndTheSeparation) {
  MotionLimits l;
  l.rotation_min = -180;
  l.rotation_max = 270;
  EXPECT_EQ(l.of(Axis::incidence), (SoftLimits{0, 85}));
  EXPECT_EQ(l.of(Axis::receive), (SoftLimits{-85, 85}));
  EXPECT_EQ(l.of(Axis::rotation), (SoftLimits{-180, 270}));
  EXPECT_EQ(l.of(Axis::tilt), (SoftLimits{-360, 360}));
  const MotionGuard g = l.guard(7);
  EXPECT_DOUBLE_EQ(g.min_separation_deg(), 7);  // unset: the caller's default
  ASSERT_TRUE(g.limits(Axis::rotation).has_value());
  EXPECT_EQ(*g.limits(Axis::rotation), (SoftLimits{-180, 270}));
  l.min_separation = 3;
  EXPECT_DOUBLE_EQ(l.guard(7).min_separation_deg(), 3);  // set: the table wins
  l.min_separation = 180;
  const auto e = error_of([&] { (void)l.guard(0); });
  EXPECT_EQ(e.code(), Errc::out_of_range);
  EXPECT_EQ(e.field(), "min_separation");
  l.min_separation.reset();
  l.tilt_min = 10;
  l.tilt_max = -10;
  const auto t = error_of([&] { (void)l.guard(0); });
  EXPECT_EQ(t.code(), Errc::out_of_range);
  EXPECT_EQ(t.field(), "tilt");
}

TEST(GuardedMotion, RejectedMovesNeverReachTheController) {
  auto rig = make(MotionLimits{});
  auto* fake = rig.fake;
  auto& motion = rig.motion;
  const auto e = error_of([&] { motion->move(Axis::incidence, 86, 1s); });
  EXPECT_EQ(e.code(), Errc::limit_violation);
  EXPECT_EQ(e.field(), "incidence");
  EXPECT_TRUE(contains(e, "86")) << e.what();
  EXPECT_TRUE(contains(e, "[0°, 85°]")) << e.what();
  EXPECT_EQ(error_of([&] { motion->move(Axis::receive, -90, 1s); }).code(), Errc::limit_violation);
  EXPECT_EQ(error_of([&] { motion->move(Axis::rotation, 400, 1s); }).code(), Errc::limit_violation);
  EXPECT_EQ(error_of([&] { motion->move(Axis::incidence, std::nan(""), 1s); }).code(),
            Errc::limit_violation);
  EXPECT_TRUE(fake->calls.empty());
  motion->move(Axis::incidence, 85, 1s);
  motion->move(Axis::rotation, -360, 1s);
  EXPECT_EQ(fake->calls, (std::vector<std::string>{"move incidence 85", "move rotation -360"}));
}

TEST(GuardedMotion, ArmCollisionUsesThePositionsReadBackFromTheController) {
  MotionLimits l;
  l.min_separation = 10;
  auto rig = make(l);
  auto* fake = rig.fake;
  auto& motion = rig.motion;
  fake->pos[Axis::incidence] = 30;
  fake->pos[Axis::receive] = 30;
  // Target too close: receive at −25° leaves the arms 5° apart.
  auto e = error_of([&] { motion->move(Axis::receive, -25, 1s); });
  EXPECT_EQ(e.code(), Errc::limit_violation);
  EXPECT_EQ(e.field(), "receive");
  EXPECT_TRUE(contains(e, "minimum separation 10")) << e.what();
  // Target fine, path not: receive from 30° to −60° sweeps through the source arm.
  e = error_of([&] { motion->move(Axis::receive, -60, 1s); });
  EXPECT_EQ(e.code(), Errc::limit_violation);
  EXPECT_TRUE(contains(e, "sweeps")) << e.what();
  EXPECT_TRUE(fake->calls.empty());
  EXPECT_EQ(fake->position_reads, 4);  // both arms, before each arm move
  // Someone else moved the source arm away: the same move is now allowed.
  fake->pos[Axis::incidence] = 80;
  motion->move(Axis::receive, -60, 1s);
  EXPECT_EQ(fake->calls, (std::vector<std::string>{"move receive -60"}));
  EXPECT_GT(fake->last_timeout.count(), 0);
  EXPECT_LE(fake->last_timeout.count(), 1000);
}

TEST(GuardedMotion, NoSeparationOrNoSecondArmReadsNoPositions) {
  auto rig = make(MotionLimits{}, 0);
  auto* fake = rig.fake;
  auto& motion = rig.motion;
  motion->move(Axis::receive, -30, 1s);
  EXPECT_EQ(fake->position_reads, 0);
  MotionLimits l;
  l.min_separation = 10;
  auto one = make(l, 0, {Axis::incidence});
  one.motion->move(Axis::incidence, 40, 1s);
  EXPECT_EQ(one.fake->position_reads, 0);
  EXPECT_EQ(one.fake->calls, (std::vector<std::string>{"move incidence 40"}));
  // Rotation and tilt only get their soft limits checked.
  auto rig2 = make(l);
  auto* fake2 = rig2.fake;
  auto& motion2 = rig2.motion;
  motion2->move(Axis::rotation, 90, 1s);
  EXPECT_EQ(fake2->position_reads, 0);
}

TEST(GuardedMotion, EverythingElsePassesThrough) {
  MotionLimits l;
  l.min_separation = 10;
  auto rig = make(l);
  auto* fake = rig.fake;
  auto& motion = rig.motion;
  fake->pos[Axis::incidence] = 120;  // outside the limits: reading and homing still work
  EXPECT_EQ(motion->axes(), (std::vector<Axis>{Axis::incidence, Axis::receive, Axis::rotation}));
  EXPECT_FALSE(motion->capabilities().homing);
  EXPECT_FALSE(motion->capabilities().feedback);
  EXPECT_DOUBLE_EQ(motion->position(Axis::incidence, 1s), 120);
  EXPECT_DOUBLE_EQ(motion->status(Axis::incidence, 1s).position_deg, 120);
  motion->home(Axis::incidence, 1s);
  motion->reset_alarm(Axis::receive, 1s);
  motion->stop(1s);
  EXPECT_EQ(fake->calls, (std::vector<std::string>{"status incidence", "home incidence",
                                                   "reset_alarm receive", "stop"}));
  EXPECT_DOUBLE_EQ(motion->guard().min_separation_deg(), 10);
  EXPECT_EQ(*motion->guard().limits(Axis::incidence), (SoftLimits{0, 85}));
  EXPECT_EQ(&motion->inner(), fake);
}

TEST(GuardedMotion, HomingIsPathCheckedWhereTheControllerKnowsItsEnd) {
  MotionLimits l;
  l.min_separation = 10;
  auto rig = make(l);
  auto* fake = rig.fake;
  auto& motion = rig.motion;
  fake->pos[Axis::incidence] = 40;
  fake->pos[Axis::receive] = 20;
  // Homing the receive arm to −40° would sweep it through the source arm (at 40°).
  fake->home_at = -40;
  const auto e = error_of([&] { motion->home(Axis::receive, 1s); });
  EXPECT_EQ(e.code(), Errc::limit_violation);
  EXPECT_EQ(e.field(), "receive");
  EXPECT_TRUE(fake->calls.empty());
  // Homing to 0° keeps 40° of clearance: it reaches the controller.
  fake->home_at = 0;
  motion->home(Axis::receive, 1s);
  EXPECT_EQ(fake->calls, (std::vector<std::string>{"home receive"}));
  EXPECT_EQ(motion->home_position(Axis::receive), 0.0);
}

TEST(GuardedMotion, NeedsAController) {
  const auto e = error_of([] { GuardedMotion g(nullptr, MotionGuard(0)); });
  EXPECT_EQ(e.code(), Errc::invalid_argument);
}
