// StorageWatch — the runner's supervision of the store (docs/architecture.md §5): the
// low-space warning, the probe of a store that cannot write, and what waits for it to write
// again (alerts held in memory, a scan state published but not stored, the recovery of the
// scans a crash left running). Runner thread, except to_json() and the setters before start.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "gonio/daemon/instrument/alerts.hpp"
#include "gonio/daemon/store/store.hpp"

namespace gonio::daemon {

class StorageWatch {
 public:
  // A scan state that could not be stored: stored once the store can write.
  struct UnsavedState {
    std::int64_t scan = 0;
    ScanState state = ScanState::paused;
    std::string reason, actor;
  };
  // Stores a scan's state (the instrument's transition(); the caller holds its lock).
  using StoreState = std::function<void(const UnsavedState&)>;

  StorageWatch(Store& store, AlertService& alerts) : store_(store), alerts_(alerts) {}

  // At most once a second: the low-space warning (raised once per episode), and whether
  // the store writes (a read-only one is probed); held alerts are flushed once it does.
  // True when it writes and there may be something waiting (write_waiting()).
  bool poll();
  // Stores what waited for the store: the unsaved state, then the recovery. The caller
  // holds the scheduler lock that `store_state` needs.
  void write_waiting(const StoreState& store_state);

  void hold(UnsavedState s) { unsaved_ = std::move(s); }
  void recover_when_writable(std::string reason) { recover_reason_ = std::move(reason); }
  // Below store.min_free_mb when last polled: no new scan starts.
  bool low_space() const { return low_space_; }
  // instrument.status's `storage`.
  nlohmann::json to_json() const;

 private:
  Store& store_;
  AlertService& alerts_;
  std::chrono::steady_clock::time_point checked_{};
  bool low_space_ = false;
  std::optional<UnsavedState> unsaved_;        // under the instrument's scheduler lock
  std::optional<std::string> recover_reason_;  // under the instrument's scheduler lock
};

}  // namespace gonio::daemon
