// The measurement first (rpc/governor.hpp), on a real goniod: clients hammering it while a
// mock scan runs flat out are held to their share, every request is still answered, and a
// technician's pause is not held.
#include <gtest/gtest.h>

#include <pthread.h>
#include <sched.h>

#include <atomic>
#include <thread>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

// The calling thread, and what it starts (goniod, forked from it), on one core: the runner,
// the twin and the clients must share it, so the measurement waits beside the clients on any
// machine. Restored at the end of the scope.
class OneCore {
 public:
  OneCore() {
    ::pthread_getaffinity_np(::pthread_self(), sizeof before_, &before_);
    cpu_set_t one;
    CPU_ZERO(&one);
    for (int c = 0; c < CPU_SETSIZE; ++c)
      if (CPU_ISSET(c, &before_)) {
        CPU_SET(c, &one);
        break;
      }
    ::pthread_setaffinity_np(::pthread_self(), sizeof one, &one);
  }
  ~OneCore() { ::pthread_setaffinity_np(::pthread_self(), sizeof before_, &before_); }

 private:
  cpu_set_t before_{};
};

TEST(Governor, HoldsHammeringClientsAndNeverAPause) {
  TempDir dir;
  OneCore pinned;
  Goniod g(dir.path, mock_config({}));
  auto c = g.unix_conn();
  const auto scan = submit(c, "governed", kTrueSample,
                           json{{"grids", {"in=15,30,45,60;out=-5:80:0.5"}}, {"repeats", 20}});
  wait_state(c, scan, {"running"});

  std::atomic<bool> stop{false};
  std::atomic<int> answered{0}, failed{0};
  std::vector<std::thread> clients;
  for (int i = 0; i < 8; ++i)
    clients.emplace_back([&, i] {
      auto conn = g.unix_conn();
      while (!stop) {
        const auto r = i % 2 ? conn.request("system.info")
                             : conn.request("scan.points", json{{"scan", scan}, {"limit", 10}});
        (r.contains("result") ? answered : failed)++;
      }
    });
  // Until the governor has held the clients for a while (it reads the kernel every 10 ms).
  json governor;
  const bool held = eventually([&] {
    governor = c.call("system.info")["governor"];
    return governor["ticks_held"].get<int>() >= 20;
  }, 60s);
  // A pause is a control method: answered while the clients are held.
  const auto before = c.call("scan.get", json{{"scan", scan}})["points_done"].get<int>();
  c.call("scan.pause", json{{"scan", scan}});
  wait_state(c, scan, {"paused"});
  c.call("scan.resume", json{{"scan", scan}});
  stop = true;
  for (auto& t : clients) t.join();

  EXPECT_TRUE(held) << governor.dump();
  EXPECT_EQ(governor["measurement_threads"].get<int>(), 1) << "the runner";
  EXPECT_GE(governor["client_threads"].get<int>(), 1);
  EXPECT_GE(governor["network_threads"].get<int>(), 2);
  EXPECT_GT(answered.load(), 0);
  EXPECT_EQ(failed.load(), 0);
  EXPECT_GT(before, 0);
  const auto sc = wait_state(c, scan, {"running"});
  EXPECT_GE(sc["points_done"].get<int>(), before);
}

TEST(Governor, AShareOfZeroTurnsItOff) {
  TempDir dir;
  MockOptions o;
  Goniod g(dir.path, [&] {
    auto cfg = mock_config(o);
    cfg.insert(cfg.find("read_timeout_s"), "client_share_busy = 0\n");
    return cfg;
  }());
  auto c = g.unix_conn();
  const auto info = c.call("system.info");
  EXPECT_EQ(info["governor"]["busy_share"], 0.0);
  EXPECT_FALSE(info["governor"]["holding"].get<bool>());
}

}  // namespace
}  // namespace gonio::test
