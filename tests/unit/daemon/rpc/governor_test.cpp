// The client governor (rpc/governor.hpp): the kernel's per-thread account it reads, and its
// decisions from one tick's readings.
#include <gtest/gtest.h>

#include <pthread.h>
#include <sched.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <future>
#include <thread>

#include <nlohmann/json.hpp>

#include "gonio/daemon/rpc/governor.hpp"

namespace gonio::daemon::rpc {
namespace {

using namespace std::chrono_literals;

double thread_cpu_s() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// Spins until this thread has used `seconds` of CPU (CPU time, not wall time).
void burn(double seconds) {
  const double end = thread_cpu_s() + seconds;
  volatile double x = 0;
  while (thread_cpu_s() < end)
    for (int i = 0; i < 1000; ++i) x = x + 1e-9;
}

TEST(ThreadTimes, CountTheCpuTheThreadUsed) {
  const auto before = thread_times(::gettid());
  ASSERT_TRUE(before.has_value()) << "the kernel keeps no schedstat";
  burn(0.05);
  const auto after = thread_times(::gettid());
  ASSERT_TRUE(after.has_value());
  EXPECT_GE(after->run_ns - before->run_ns, 40'000'000u);
  EXPECT_FALSE(thread_times(0x7ffffff0).has_value());  // no such thread
}

TEST(ThreadTimes, CountTheWaitOfTwoThreadsOnOneCore) {
  // Two threads that want the same single core: each waits while the other runs.
  std::atomic<std::uint64_t> waited{0};
  const auto spin_on_cpu0 = [&] {
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(0, &one);
    ASSERT_EQ(::pthread_setaffinity_np(::pthread_self(), sizeof one, &one), 0);
    const auto before = thread_times(::gettid());
    burn(0.1);
    const auto after = thread_times(::gettid());
    waited += after->wait_ns - before->wait_ns;
  };
  std::thread a(spin_on_cpu0), b(spin_on_cpu0);
  a.join();
  b.join();
  EXPECT_GT(waited.load(), 10'000'000u);
}

ClientGovernor::Tick tick(double measurement_wait_ms, double client_run_ms, double elapsed_ms = 10) {
  return {.measurement_run_ns = 5'000'000,
          .measurement_wait_ns = static_cast<std::uint64_t>(measurement_wait_ms * 1e6),
          .client_run_ns = static_cast<std::uint64_t>(client_run_ms * 1e6),
          .elapsed_ns = static_cast<std::uint64_t>(elapsed_ms * 1e6)};
}

ClientGovernor::Settings settings() {
  return {.tick = 10ms, .busy_share = 0.05, .wait_threshold = 0.02, .linger = 50ms};
}

TEST(ClientGovernor, HoldsClientsOnlyWhileTheMeasurementWaitsBesideThem) {
  ClientGovernor g(settings(), false);
  g.observe(tick(0, 8));     // clients busy, the measurement never waited
  EXPECT_FALSE(g.holding());
  g.observe(tick(3, 0));     // it waited, but no client ran: holding them would not help
  EXPECT_FALSE(g.holding());
  g.observe(tick(3, 0.4));   // nor clients within their share (0.5 ms of 10)
  EXPECT_FALSE(g.holding());
  g.observe(tick(0.1, 5));   // 1 % of the tick: below the threshold
  EXPECT_FALSE(g.holding());
  g.observe({.measurement_run_ns = 1'000'000, .measurement_wait_ns = 1'000'000, .client_run_ns = 5'000'000,
             .elapsed_ns = 10'000'000});  // it waited, but wants only a fifth of the tick
  EXPECT_FALSE(g.holding());
  g.observe(tick(3, 5));     // slowed beside clients
  EXPECT_TRUE(g.holding());
  EXPECT_EQ(g.stats()["ticks_held"], 1);
}

TEST(ClientGovernor, LetsGoAfterTheLingerWithoutWaits) {
  ClientGovernor g(settings(), false);
  g.observe(tick(3, 5));
  ASSERT_TRUE(g.holding());
  for (int i = 0; i < 4; ++i) {
    g.observe(tick(0, 0.1));
    EXPECT_TRUE(g.holding()) << "tick " << i;
  }
  g.observe(tick(0, 0.1));   // five ticks of 10 ms: the 50 ms linger is over
  EXPECT_FALSE(g.holding());
}

TEST(ClientGovernor, PacesClientWorkToItsShareWhileHolding) {
  auto s = settings();
  s.linger = 1s;  // every tick below is within it
  ClientGovernor g(s, false);
  g.wait_turn();  // not holding: returns at once
  const auto turn = [&] { return std::async(std::launch::async, [&] { g.wait_turn(); }); };
  // Clients used 2 ms of a 10 ms tick; their share is 0.5 ms: 1.5 ms over. While overdrawn,
  // one request a tick goes ahead, and no more.
  g.observe(tick(3, 2));
  ASSERT_TRUE(g.holding());
  EXPECT_EQ(turn().wait_for(5s), std::future_status::ready) << "the tick's one request";
  auto second = turn();
  EXPECT_EQ(second.wait_for(50ms), std::future_status::timeout) << "ran beyond its share";
  g.observe(tick(3, 0));  // +0.5 ms: still 1.0 ms over; the next tick's one request
  EXPECT_EQ(second.wait_for(5s), std::future_status::ready);
  auto third = turn();
  EXPECT_EQ(third.wait_for(50ms), std::future_status::timeout);
  g.observe(tick(3, 0));  // 0.5 ms over
  EXPECT_EQ(third.wait_for(5s), std::future_status::ready);
  auto fourth = turn();
  EXPECT_EQ(fourth.wait_for(50ms), std::future_status::timeout);
  g.observe(tick(3, 0));  // repaid: everyone goes
  EXPECT_EQ(fourth.wait_for(5s), std::future_status::ready);
  EXPECT_EQ(turn().wait_for(5s), std::future_status::ready);
  // Quiet ticks do not save up more than one tick's share.
  for (int i = 0; i < 10; ++i) g.observe(tick(3, 0.1));
  ASSERT_TRUE(g.holding());
  g.observe(tick(3, 1.5));  // 1.5 ms used against at most 0.5 + 0.5 ms
  EXPECT_EQ(turn().wait_for(5s), std::future_status::ready);
  auto again = turn();
  EXPECT_EQ(again.wait_for(50ms), std::future_status::timeout);
  g.stop();  // shutdown releases every waiter
  EXPECT_EQ(again.wait_for(5s), std::future_status::ready);
}

TEST(ClientGovernor, AShareOfZeroNeverHolds) {
  auto s = settings();
  s.busy_share = 0;
  ClientGovernor g(s, false);
  g.observe(tick(9, 9));
  EXPECT_FALSE(g.holding());
}

TEST(ClientGovernor, ItsSamplerFindsTheMarkedThreads) {
  ClientGovernor g(settings());
  std::atomic<bool> done{false};
  std::thread measuring([&] {
    mark_measurement_thread();
    while (!done) burn(0.005);
  });
  std::thread client([&] {
    mark_client_thread();
    while (!done) burn(0.005);
  });
  bool seen = false;
  for (int i = 0; i < 500 && !seen; ++i) {
    std::this_thread::sleep_for(10ms);
    const auto st = g.stats();
    seen = st["measurement_threads"].get<int>() >= 1 && st["client_threads"].get<int>() >= 1 &&
           st["client_cpu_s"].get<double>() > 0;
  }
  done = true;
  measuring.join();
  client.join();
  EXPECT_TRUE(seen) << g.stats().dump();
}

}  // namespace
}  // namespace gonio::daemon::rpc
