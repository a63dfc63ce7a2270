// Retention (store.retention_days): a thread that prunes, now and then, the points of
// finished scans older than the retention that the central archive has committed
// (Store::prune_archived), and returns their space to the file system.
//
// Without [archive] nothing is shipped, so nothing is ever prunable: the keeper says so at
// start and runs no thread. The check runs at start and then every quarter of the retention,
// at least every second and at most every hour.
#pragma once

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "gonio/daemon/store/store.hpp"

namespace gonio::daemon {

class RetentionKeeper {
 public:
  // `days` 0: off. `archive`: whether an archive is configured.
  RetentionKeeper(Store& store, double days, bool archive);
  ~RetentionKeeper();
  RetentionKeeper(const RetentionKeeper&) = delete;
  RetentionKeeper& operator=(const RetentionKeeper&) = delete;

  void start();
  void stop();
  // One pass: every prunable scan, in batches (what the thread does each period).
  Store::PruneResult run_once();

 private:
  Store& store_;
  std::chrono::milliseconds retention_;
  bool active_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace gonio::daemon
