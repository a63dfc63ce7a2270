// TwinService — the twin's worker pool inside goniod.
//
// Predictions of a scan are computed ahead of the arms: a Batch keeps up to `window`
// geometries in flight beyond the one the runner waits for, in measuring order, and frees
// predictions once the runner has moved past them (memory stays bounded for long scans).
// twin.predict requests from the API use the same pool. Workers are plain threads: the
// twin is CPU-bound and thread-safe (Twin::predict).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "gonio/daemon/config/config.hpp"
#include "gonio/daemon/instrument/scan_twin.hpp"
#include "gonio/proto/geometry.hpp"
#include "gonio/twin/instrument.hpp"
#include "gonio/twin/twin.hpp"

namespace gonio::daemon {

class TwinService {
 public:
  TwinService(const Config& config, twin::InstrumentProfile profile);
  ~TwinService();
  TwinService(const TwinService&) = delete;
  TwinService& operator=(const TwinService&) = delete;

  // The current instrument profile (a copy: a calibration may replace it at any time).
  twin::InstrumentProfile profile() const;
  // Its version in the store (0: the configured profile, not calibrated).
  std::int64_t profile_version() const;
  // Replaces the profile for twins made from now on (scans started later, twin.predict);
  // twins already made keep theirs. `calibrated_at`: when the calibration that made it ran.
  void set_profile(twin::InstrumentProfile profile, std::int64_t version,
                   std::string calibrated_at = {});
  // {"name", "version" (0: as configured), "calibrated_at" (UTC, null when not calibrated)}
  nlohmann::json profile_info() const;
  const twin::EstimatorOptions& options() const noexcept { return options_; }
  unsigned threads() const noexcept { return static_cast<unsigned>(workers_.size()); }
  // "gonio-twin <version> rqmc rel_se=0.002 R=16 seed=1 profile=gcms4"; a calibrated
  // profile adds its version: "profile=gcms4#2".
  std::string version() const;

  // The profile with its version and version() at one instant (what a scan runs with).
  struct Snapshot {
    twin::InstrumentProfile profile;
    std::int64_t profile_version = 0;
    std::string twin_version;
  };
  Snapshot snapshot() const;

  // A twin for a BSDF spec on `grid`; throws Error naming `field` (e.g. "bsdf").
  std::shared_ptr<const twin::Twin> make(const std::string& bsdf, const WavelengthGrid& grid,
                                         const std::string& field = "bsdf") const;
  // The same with a given profile (a snapshot's).
  std::shared_ptr<const twin::Twin> make(const std::string& bsdf, const WavelengthGrid& grid,
                                         const std::string& field,
                                         const twin::InstrumentProfile& profile) const;

  class Batch {
   public:
    // Blocks until the prediction of geometry `i` is ready (rethrows its error). Moves the
    // look-ahead window forward and frees earlier predictions.
    ScanTwin::PointPrediction wait(std::size_t i);
    void cancel();
    ~Batch();

   private:
    friend class TwinService;
    struct State;
    Batch(TwinService& pool, std::shared_ptr<const ScanTwin> twin, std::vector<Geometry> geoms,
          std::size_t first, std::size_t window);
    void submit_upto(std::size_t end);  // caller holds state_->mu

    TwinService& pool_;
    std::shared_ptr<const ScanTwin> twin_;
    std::vector<Geometry> geometries_;
    std::size_t window_;
    std::shared_ptr<State> state_;  // shared with queued tasks, which may outlive the batch
  };

  // Starts predicting geometries from index `first` on: each prediction with its budget and
  // the sample's sensitivities (ScanTwin).
  std::shared_ptr<Batch> batch(std::shared_ptr<const ScanTwin> twin, std::vector<Geometry> geometries,
                               std::size_t first = 0, std::size_t window = 0);

  // Predicts every geometry (blocking; uses the pool). Results in order.
  std::vector<twin::Prediction> predict(const twin::Twin& twin, const std::vector<Geometry>& geometries,
                                        const twin::EstimatorOptions& options);

  std::size_t queued() const;

 private:
  void post(std::function<void()> task);
  void work();

  mutable std::mutex profile_mu_;
  twin::InstrumentProfile profile_;
  std::int64_t profile_version_ = 0;
  std::string calibrated_at_;
  std::string version_;
  twin::EstimatorOptions options_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> tasks_;
  bool stopping_ = false;
  std::vector<std::thread> workers_;
};

}  // namespace gonio::daemon
