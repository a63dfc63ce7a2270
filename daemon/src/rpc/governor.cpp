// The client governor (see governor.hpp).
#include "gonio/daemon/rpc/governor.hpp"

#include <fcntl.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace gonio::daemon::rpc {

namespace {

enum class Kind { measurement, client, network };

struct Registry {
  std::mutex mu;
  std::vector<std::pair<pid_t, Kind>> threads;
};
Registry& registry() {
  static Registry r;
  return r;
}

void mark(Kind k) {
  const pid_t tid = ::gettid();
  auto& r = registry();
  std::lock_guard lock(r.mu);
  for (auto& [t, kind] : r.threads)
    if (t == tid) {
      kind = k;
      return;
    }
  r.threads.emplace_back(tid, k);
}

// A thread's CPU clock from its id (the kernel's CPUCLOCK_SCHED encoding of a thread clock,
// as glibc's pthread_getcpuclockid builds it): cheaper than reading /proc for client threads.
clockid_t thread_clock(pid_t tid) { return static_cast<clockid_t>((~static_cast<unsigned>(tid) << 3) | 6u); }

std::optional<std::uint64_t> thread_cpu_ns(pid_t tid) {
  timespec ts{};
  if (::clock_gettime(thread_clock(tid), &ts) != 0) return std::nullopt;
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ull + static_cast<std::uint64_t>(ts.tv_nsec);
}

}  // namespace

std::optional<ThreadTimes> thread_times(pid_t tid) {
  const auto path = fmt::format("/proc/self/task/{}/schedstat", tid);
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return std::nullopt;
  char buf[128];
  const auto n = ::read(fd, buf, sizeof buf - 1);
  ::close(fd);
  if (n <= 0) return std::nullopt;
  buf[n] = '\0';
  unsigned long long run = 0, wait = 0;
  if (std::sscanf(buf, "%llu %llu", &run, &wait) != 2) return std::nullopt;
  return ThreadTimes{run, wait};
}

void mark_measurement_thread() { mark(Kind::measurement); }
void mark_client_thread() { mark(Kind::client); }
void mark_network_thread() { mark(Kind::network); }

ClientGovernor::ClientGovernor(Settings s, bool sample) : settings_(s), last_(std::chrono::steady_clock::now()) {
  if (sample && settings_.busy_share > 0) sampler_ = std::thread([this] { sample_loop(); });
}

ClientGovernor::~ClientGovernor() { stop(); }

void ClientGovernor::stop() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (sampler_.joinable()) sampler_.join();
}

void ClientGovernor::wait_turn() {
  if (!holding()) return;
  std::unique_lock lock(mu_);
  // A negative balance is client CPU spent beyond the share: wait until the ticks repay it.
  // One request a tick goes ahead whatever the balance: the network threads' CPU, which is
  // not all requests' (notifications follow the scan), must not stop requests altogether.
  cv_.wait(lock, [&] { return stopping_ || !holding_.load() || balance_ns_ >= 0 || grant_; });
  if (holding_.load() && balance_ns_ < 0) grant_ = false;
}

void ClientGovernor::observe(const Tick& t) {
  {
    std::lock_guard lock(mu_);
    ++tick_no_;
    client_total_ns_ += t.client_run_ns;
    measurement_wait_total_ns_ += t.measurement_wait_ns;
    // Slowed beside clients that took more than their share: holding clients that stay
    // within it would not help the measurement (it waits for someone else).
    const double elapsed = static_cast<double>(t.elapsed_ns);
    // ... and only a measurement that wants the CPU most of the tick (a runner that waits for
    // the arms, or does a point's arithmetic in a millisecond now and then, is not slowed in
    // any way that matters by a client's request).
    const bool slowed = t.elapsed_ns > 0 &&
                        static_cast<double>(t.measurement_run_ns + t.measurement_wait_ns) >=
                            settings_.busy_fraction * elapsed &&
                        static_cast<double>(t.client_run_ns + t.network_run_ns) > settings_.busy_share * elapsed &&
                        static_cast<double>(t.measurement_wait_ns) > settings_.wait_threshold * elapsed;
    if (slowed) ticks_since_wait_ = 0;
    else ++ticks_since_wait_;
    const auto linger_ticks = static_cast<std::uint64_t>(
        std::max<std::int64_t>(1, settings_.linger.count() / std::max<std::int64_t>(1, settings_.tick.count())));
    const bool hold = settings_.busy_share > 0 && (slowed || (holding_.load() && ticks_since_wait_ < linger_ticks));
    if (hold) {
      ++ticks_held_;
      // The share earned in this tick, less what the client threads used; a surplus is not
      // saved beyond one tick's share (no bursts after a quiet spell).
      const auto earned = static_cast<std::int64_t>(settings_.busy_share * static_cast<double>(t.elapsed_ns));
      if (!holding_.load()) balance_ns_ = 0;
      balance_ns_ = std::min(balance_ns_ + earned - static_cast<std::int64_t>(t.client_run_ns + t.network_run_ns),
                             earned);
      grant_ = true;
    } else {
      balance_ns_ = 0;
    }
    holding_.store(hold);
  }
  cv_.notify_all();
}

ClientGovernor::Tick ClientGovernor::read_tick() {
  std::vector<std::pair<pid_t, Kind>> threads;
  {
    auto& r = registry();
    std::lock_guard lock(r.mu);
    threads = r.threads;
  }
  Tick t;
  const auto now = std::chrono::steady_clock::now();
  t.elapsed_ns = static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(now - last_).count());
  last_ = now;
  std::vector<Seen> next;
  next.reserve(threads.size());
  std::size_t measuring = 0, clients = 0, network = 0;
  for (const auto& entry : threads) {
    const pid_t tid = entry.first;  // not a structured binding: the lambda below captures it
    const Kind kind = entry.second;
    ThreadTimes cur;
    if (kind == Kind::measurement) {
      const auto tt = thread_times(tid);
      if (!tt) continue;
      cur = *tt;
      ++measuring;
    } else {
      const auto ns = thread_cpu_ns(tid);
      if (!ns) continue;
      cur.run_ns = *ns;
      ++(kind == Kind::client ? clients : network);
    }
    const auto it = std::find_if(seen_.begin(), seen_.end(), [&](const Seen& s) { return s.tid == tid; });
    if (it != seen_.end()) {
      const auto run = cur.run_ns >= it->t.run_ns ? cur.run_ns - it->t.run_ns : 0;
      const auto wait = cur.wait_ns >= it->t.wait_ns ? cur.wait_ns - it->t.wait_ns : 0;
      if (kind == Kind::measurement) {
        t.measurement_run_ns += run;
        t.measurement_wait_ns += wait;
      } else {
        (kind == Kind::client ? t.client_run_ns : t.network_run_ns) += run;
      }
    }
    next.push_back({tid, cur});
  }
  seen_ = std::move(next);
  std::lock_guard lock(mu_);
  measurement_threads_ = measuring;
  client_threads_ = clients;
  network_threads_ = network;
  return t;
}

void ClientGovernor::sample_loop() {
  // While the measurement does not run, look ten times less often: nothing to protect.
  auto tick = settings_.tick;
  std::unique_lock lock(mu_);
  while (!stopping_) {
    cv_.wait_for(lock, tick, [&] { return stopping_; });
    if (stopping_) break;
    lock.unlock();
    const auto t = read_tick();
    observe(t);
    tick = t.measurement_run_ns > 0 || holding() ? settings_.tick : 10 * settings_.tick;
    lock.lock();
  }
}

void ClientGovernor::write_stats(JsonWriter& w) const {
  std::lock_guard lock(mu_);
  w.member("holding", holding_.load())
      .member("busy_share", settings_.busy_share)
      .member("ticks_held", ticks_held_)
      .member("client_cpu_s", 1e-9 * static_cast<double>(client_total_ns_))
      .member("measurement_wait_s", 1e-9 * static_cast<double>(measurement_wait_total_ns_))
      .member("measurement_threads", measurement_threads_)
      .member("client_threads", client_threads_)
      .member("network_threads", network_threads_);
}

nlohmann::json ClientGovernor::stats() const {
  std::string text = "{";
  JsonWriter w(text);
  write_stats(w);
  w.end_object();
  return nlohmann::json::parse(text);
}

}  // namespace gonio::daemon::rpc
