// Wall-clock steps (NTP) against a real goniod under libfaketime: the daemon's wall clock is
// stepped back and forward by an hour or more while its monotonic clock runs on, as after an
// NTP step. A scan's not_before is a wall-clock time: it must start neither before it (a
// step back) nor later than the first scheduler turn after it (a step forward past it), and
// a running scan's timeouts (steady clock) must not fire or stall over a step.
// Without libfaketime (Debian package faketime) the tests skip and say so.
#include <glob.h>

#include <chrono>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>

#include "gonio/proto/scan.hpp"
#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

std::string faketime_library() {
  glob_t g{};
  std::string found;
  if (::glob("/usr/lib/*/faketime/libfaketimeMT.so.1", 0, nullptr, &g) == 0 && g.gl_pathc > 0) found = g.gl_pathv[0];
  ::globfree(&g);
  return found;
}

// goniod whose wall clock is real time plus the offset in `offset_file`, read at every call.
class SteppedGoniod {
 public:
  SteppedGoniod(const fs::path& dir, const std::string& lib, const std::string& config)
      : offset_file_(dir / "clock-offset") {
    step_to(0);
    goniod_.emplace(dir / "state", config,
                    std::vector<std::string>{"LD_PRELOAD=" + lib, "FAKETIME_TIMESTAMP_FILE=" + offset_file_.string(),
                                             "FAKETIME_NO_CACHE=1", "FAKETIME_DONT_FAKE_MONOTONIC=1"});
  }
  // The daemon's wall clock becomes real time + `seconds` (a step, as NTP makes one).
  void step_to(long seconds) {
    std::ofstream(offset_file_) << (seconds >= 0 ? "+" : "") << seconds << "\n";
  }
  Goniod& operator*() { return *goniod_; }
  Goniod* operator->() { return &*goniod_; }

 private:
  fs::path offset_file_;
  std::optional<Goniod> goniod_;
};

std::string iso_in(std::chrono::seconds from_now) {
  return utc::format(std::chrono::system_clock::now() + from_now);
}

// The scheduler looks at the wall clock at least once a second; a scan that must not start
// is still queued after a few of its turns.
void let_the_scheduler_turn() { std::this_thread::sleep_for(std::chrono::milliseconds(2500)); }

TEST(ClockStep, BackwardStepNeitherStartsANotBeforeScanEarlyNorDelaysItOnceDue) {
  const auto lib = faketime_library();
  if (lib.empty()) GTEST_SKIP() << "libfaketime is not installed (Debian package faketime)";
  TempDir dir;
  SteppedGoniod g(dir.path, lib, mock_config({}));
  auto c = g->unix_conn();
  const auto id = submit(c, "tile", kTrueSample,
                         json{{"grids", {"in=45;out=0:20:10"}}, {"not_before", iso_in(std::chrono::seconds(60))}});
  g.step_to(-3600);  // an hour back: not_before is now 61 minutes away on goniod's clock
  // The step is in effect: goniod stamps what it stores with its own wall clock.
  const auto stamped = utc::parse(c.call("sample.create", json{{"name", "probe"}})["created_at"].get<std::string>());
  ASSERT_LT(stamped, std::chrono::system_clock::now() - std::chrono::minutes(50)) << "libfaketime did not take";
  let_the_scheduler_turn();
  EXPECT_EQ(c.call("scan.get", json{{"scan", id}})["state"], "queued");
  g.step_to(120);  // past not_before: due at once, not in the 60 s or the hour counted before
  EXPECT_EQ(wait_state(c, id, {"completed", "paused", "failed"}, 20s)["state"], "completed") << g->log_text();
}

TEST(ClockStep, ForwardStepPastNotBeforeStartsTheScanAtOnce) {
  const auto lib = faketime_library();
  if (lib.empty()) GTEST_SKIP() << "libfaketime is not installed (Debian package faketime)";
  TempDir dir;
  SteppedGoniod g(dir.path, lib, mock_config({}));
  auto c = g->unix_conn();
  const auto id = submit(c, "tile", kTrueSample,
                         json{{"grids", {"in=45;out=0:20:10"}}, {"not_before", iso_in(std::chrono::hours(1))}});
  let_the_scheduler_turn();
  EXPECT_EQ(c.call("scan.get", json{{"scan", id}})["state"], "queued");
  g.step_to(2 * 3600);
  EXPECT_EQ(wait_state(c, id, {"completed", "paused", "failed"}, 20s)["state"], "completed") << g->log_text();
}

TEST(ClockStep, StepsDuringAScanFireNoTimeoutAndStallNothing) {
  const auto lib = faketime_library();
  if (lib.empty()) GTEST_SKIP() << "libfaketime is not installed (Debian package faketime)";
  TempDir dir;
  MockOptions o;
  o.time_scale = 0.02;  // real moves, bounded by instrument.move_timeout_s
  o.extra = "[instrument]\nmove_timeout_s = 5\nmeasure_timeout_s = 5\n";
  SteppedGoniod g(dir.path, lib, mock_config(o));
  auto c = g->unix_conn();
  const auto id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:5"}}});  // 13 points
  ASSERT_TRUE(eventually([&] { return c.call("scan.get", json{{"scan", id}})["points_done"].get<int>() >= 2; }));
  g.step_to(-3 * 3600);
  ASSERT_TRUE(eventually([&] { return c.call("scan.get", json{{"scan", id}})["points_done"].get<int>() >= 6; }));
  g.step_to(5 * 3600);
  const auto sc = wait_state(c, id, {"completed", "paused", "failed"}, 30s);
  EXPECT_EQ(sc["state"], "completed") << sc.dump() << g->log_text();
  EXPECT_EQ(c.call("instrument.status")["fault_latched"], false);
}

}  // namespace
}  // namespace gonio::test
