// The measurement first: client work gets the CPU that the measurement does not want
// (docs/architecture.md §5).
//
// Thread priorities alone cannot promise that. A client thread ten nice steps down weighs a
// tenth of a runner thread, but there are many of them, and a load generator or a browser on
// the same machine runs at full weight. So the governor watches the measurement itself: the
// scan runner says who it is (mark_measurement_thread), and every tick the governor reads
// from the kernel how long it was runnable but waiting for a core
// (/proc/self/task/<tid>/schedstat, the run-queue delay). While they wait — the measurement is
// being slowed by someone — client work is held to a small share of one core
// (`server.client_share_busy`), counted from the CPU time of the threads that serve clients
// (the RPC workers and the network threads), with at least one request a tick let through so
// that notifications, which follow the scan's pace, cannot stop requests; when they stop
// waiting for a while, client work is free again. Control methods (pause, resume, cancel,
// reset) run on threads of their own and are never held.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <sys/types.h>
#include <thread>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "gonio/proto/json_writer.hpp"

namespace gonio::daemon::rpc {

// The kernel's account of one thread: time on a CPU and time runnable but waiting for one
// (schedstat(5) fields 1 and 2), in nanoseconds. nullopt: the thread is gone, or the kernel
// keeps no such account.
struct ThreadTimes {
  std::uint64_t run_ns = 0, wait_ns = 0;
};
std::optional<ThreadTimes> thread_times(pid_t tid);

// The calling thread does the measurement (the scan runner) or client work
// (network threads, RPC workers). Process-wide, for the governor to read; a thread that exits
// is dropped when the kernel no longer knows it.
void mark_measurement_thread();
void mark_client_thread();   // runs client requests (the RPC workers)
void mark_network_thread();  // reads, writes and pushes for clients (the io threads)

class ClientGovernor {
 public:
  struct Settings {
    std::chrono::milliseconds tick{10};
    // Client CPU while the measurement waits for a core: cores' worth (0.05 = 5 % of one).
    double busy_share = 0.05;
    // The measurement counts as slowed when its threads together waited this share of a tick.
    double wait_threshold = 0.02;
    // ... and was runnable (running or waiting) for at least this share of it: the
    // measurement is bound by the CPU, not by its devices.
    double busy_fraction = 0.5;
    // How long client work stays held after the measurement last waited.
    std::chrono::milliseconds linger{500};
  };
  // One tick's readings: the measurement threads' summed run and wait, and the client threads'
  // summed run, all in nanoseconds since the previous tick.
  struct Tick {
    std::uint64_t measurement_run_ns = 0, measurement_wait_ns = 0, client_run_ns = 0;
    std::uint64_t elapsed_ns = 0;
    std::uint64_t network_run_ns = 0;  // the network threads' CPU (reading, writing, pushing)
  };

  // `sample`: starts the thread that reads the kernel every tick; false for tests that feed
  // ticks through observe().
  explicit ClientGovernor(Settings s, bool sample = true);
  ~ClientGovernor();
  ClientGovernor(const ClientGovernor&) = delete;
  ClientGovernor& operator=(const ClientGovernor&) = delete;

  // Client work calls this before it runs: it returns at once unless client work is held and
  // its share of the current tick is spent, and then waits for a tick with room (or stop()).
  void wait_turn();
  // True while client work is held: requests that would run on a network thread are handed
  // to the RPC workers instead, where wait_turn paces them.
  bool holding() const noexcept { return holding_.load(std::memory_order_relaxed); }

  // Feeds one tick's readings (the sampler thread does this every tick).
  void observe(const Tick& t);
  void stop();

  // system.info's "governor": {holding, busy_share, ticks_held, client_cpu_s,
  // measurement_wait_s, measurement_threads, client_threads, network_threads}. write_stats
  // writes the members into an open object; stats() is the same as a tree.
  void write_stats(JsonWriter& w) const;
  nlohmann::json stats() const;

 private:
  void sample_loop();
  Tick read_tick();

  const Settings settings_;
  std::atomic<bool> holding_{false};
  mutable std::mutex mu_;
  std::condition_variable cv_;
  bool stopping_ = false;
  std::uint64_t tick_no_ = 0;
  // While holding: client CPU earned (busy_share of each tick) less client CPU used; client
  // work waits while it is negative.
  std::int64_t balance_ns_ = 0;
  bool grant_ = false;  // the one request of this tick that goes ahead while overdrawn
  std::uint64_t ticks_since_wait_ = 0;
  std::uint64_t ticks_held_ = 0, client_total_ns_ = 0, measurement_wait_total_ns_ = 0;
  std::size_t measurement_threads_ = 0, client_threads_ = 0, network_threads_ = 0;
  // Last readings per thread (the sampler's own state).
  struct Seen {
    pid_t tid;
    ThreadTimes t;
  };
  std::vector<Seen> seen_;
  std::chrono::steady_clock::time_point last_;
  std::thread sampler_;
};

}  // namespace gonio::daemon::rpc
