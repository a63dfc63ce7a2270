// The runner's supervision of the store (storage_watch.hpp).
#include "gonio/daemon/instrument/storage_watch.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/proto/error.hpp"

namespace gonio::daemon {

using nlohmann::json;

bool StorageWatch::poll() {
  const auto now = std::chrono::steady_clock::now();
  if (now - checked_ < std::chrono::seconds(1)) return false;
  checked_ = now;
  // The low-space warning first: on a store that cannot write it is held in memory.
  const auto s = store_.storage();
  if (s.low && !low_space_) {
    low_space_ = true;
    const auto msg = fmt::format("low space: {}; no new scan starts until {:.0f} MiB are free (store.min_free_mb)",
                                 describe_space(s.dir, s.space), static_cast<double>(s.min_free_bytes) / (1 << 20));
    spdlog::warn("store: {}", msg);
    alerts_.raise(AlertDraft{.kind = std::string(alert_kind::storage),
                             .severity = Severity::warning,
                             .dedup_key = "storage:low",
                             .message = msg});
  } else if (!s.low && low_space_) {
    low_space_ = false;
    spdlog::info("store: space is back ({})", describe_space(s.dir, s.space));
  }
  if (!store_.writable() && !store_.probe()) return false;
  alerts_.flush_held();
  return unsaved_ || recover_reason_;
}

void StorageWatch::write_waiting(const StoreState& store_state) {
  if (unsaved_) {
    try {
      const auto u = *unsaved_;
      store_state(u);
      unsaved_.reset();
      spdlog::info("scan {}: state {} stored now that the store can write", u.scan, to_text(u.state));
    } catch (const Error& e) {
      spdlog::warn("scan {}: state still not stored: {}", unsaved_->scan, e.what());
    }
  }
  if (recover_reason_) {
    try {
      for (const auto id : store_.recover_running(*recover_reason_))
        spdlog::warn("scan {} was running when goniod last stopped; it resumes first", id);
      recover_reason_.reset();
    } catch (const Error& e) {
      spdlog::warn("store: scans left running not recovered yet: {}", e.what());
    }
  }
}

json StorageWatch::to_json() const {
  const auto s = store_.storage();
  json held = json::array();
  for (const auto& a : alerts_.held()) held.push_back(a);
  return json{{"dir", s.dir.string()},
              {"free_mb", s.space.known ? json(static_cast<double>(s.space.free_bytes) / (1 << 20)) : json(nullptr)},
              {"read_only_fs", s.space.read_only},
              {"writable", s.writable},
              {"low", s.low},
              {"fault", s.fault},
              {"min_free_mb", static_cast<double>(s.min_free_bytes) / (1 << 20)},
              {"reserve", s.reserve},
              {"unsaved_alerts", std::move(held)}};
}

}  // namespace gonio::daemon
