// The retention thread (retention.hpp).
#include "gonio/daemon/store/retention.hpp"

#include <algorithm>

#include <spdlog/spdlog.h>

#include "gonio/proto/error.hpp"

namespace gonio::daemon {

using namespace std::chrono_literals;

RetentionKeeper::RetentionKeeper(Store& store, double days, bool archive)
    : store_(store),
      retention_(std::chrono::milliseconds(static_cast<std::int64_t>(days * 86400e3))),
      active_(days > 0 && archive) {
  if (days > 0 && !archive)
    spdlog::warn("store.retention_days = {} but no [archive] is configured: nothing is shipped, so no point "
                 "is pruned",
                 days);
  else if (active_)
    spdlog::info("store: points the archive holds are pruned {} days after their scan finished", days);
}

RetentionKeeper::~RetentionKeeper() { stop(); }

void RetentionKeeper::start() {
  if (!active_ || thread_.joinable()) return;
  const auto period = std::clamp<std::chrono::milliseconds>(retention_ / 4, 1s, 1h);
  thread_ = std::thread([this, period] {
    std::unique_lock lock(mu_);
    while (!stopping_) {
      lock.unlock();
      try {
        run_once();
      } catch (const Error& e) {  // a full disk, say: try again next time
        spdlog::warn("store: pruning failed: {}", e.what());
      }
      lock.lock();
      cv_.wait_for(lock, period, [this] { return stopping_; });
    }
  });
}

void RetentionKeeper::stop() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

Store::PruneResult RetentionKeeper::run_once() {
  Store::PruneResult total;
  if (!active_) return total;
  const auto before = utc::format(std::chrono::system_clock::now() - retention_);
  for (;;) {
    const auto r = store_.prune_archived(before);
    total.scans += r.scans;
    total.points += r.points;
    total.pages_freed += r.pages_freed;
    if (r.scans == 0) break;
    std::lock_guard lock(mu_);
    if (stopping_) break;
  }
  if (total.scans > 0)
    spdlog::info("store: pruned the points of {} archived scans ({} points, {} pages returned)", total.scans,
                 total.points, total.pages_freed);
  return total;
}

}  // namespace gonio::daemon
