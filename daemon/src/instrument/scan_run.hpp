// ScanRun — the run of one scan on the runner thread: its state (the point to measure next,
// the reference white in hand, the twin's predictions, the evidence for the verdict, an
// adaptive scan's loop) and the steps of one point (docs/architecture.md §6, steps 3–8).
// The Instrument owns the run, calls its steps in order and acts on their faults.
//
// The fault convention of the steps, the one rule of §6: a step that cannot finish throws
// a PointFault naming the party that failed — the motion controller, the photometer or the
// store — and changes nothing of the scan's state; Instrument::step() alone acts on it. Any
// other exception out of a step is a defect, and fails the scan.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "gonio/daemon/config/config.hpp"
#include "gonio/daemon/instrument/adaptive_loop.hpp"
#include "gonio/daemon/instrument/alerts.hpp"
#include "gonio/daemon/instrument/arm_moves.hpp"
#include "gonio/daemon/instrument/auto_ranger.hpp"
#include "gonio/daemon/instrument/divergence.hpp"
#include "gonio/daemon/instrument/point_reduction.hpp"
#include "gonio/daemon/instrument/twin_service.hpp"
#include "gonio/daemon/instrument/verdict.hpp"
#include "gonio/daemon/rpc/hub.hpp"
#include "gonio/daemon/store/store.hpp"
#include "gonio/drivers/motion/motion_controller.hpp"
#include "gonio/drivers/photometer/photometer.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {

// A failure of a device's link rather than of one request: the device is closed and opened
// again (Instrument::drop_device).
inline bool is_link_error(Errc c) { return c == Errc::disconnected || c == Errc::io_error; }

// Who failed a point step.
enum class FaultParty { motion, photometer, store };

// A point step that could not finish, and whose failure it was (scan_run.hpp's rule).
class PointFault : public Error {
 public:
  PointFault(FaultParty party, const Error& e) : Error(e), party_(party) {}
  FaultParty party() const noexcept { return party_; }

 private:
  FaultParty party_;
};

// What a run works with; owned by the daemon.
struct RunContext {
  const Config& config;
  Store& store;
  TwinService& twin;
  AlertService& alerts;
  Hub& hub;
  const DivergenceSettings& divergence;
  const drivers::MotionGuard& guard;
  std::function<void()> beat;
  // (scan, alert): a scan ended with a sustained divergence alert whose verdict names a cause.
  std::function<void(std::int64_t, std::int64_t)> sustained;
};

// The devices for step 3, and where the axes stand.
struct PointDevices {
  drivers::MotionController& motion;
  drivers::Photometer& photometer;
  const ArmMover& arms;
  AutoRanger& ranger;
  AxisPositions at;
  bool has_rotation = false;
};

class ScanRun {
 public:
  using Clock = std::chrono::steady_clock;

  // Prepares the run of `scan`: its resume point and the stored points' evidence, the twin's
  // predictions ahead, an adaptive scan's loop (from `arms`, where the arms stand).
  ScanRun(const RunContext& ctx, const Scan& scan, std::optional<Geometry> arms);
  ~ScanRun();
  ScanRun(const ScanRun&) = delete;
  ScanRun& operator=(const ScanRun&) = delete;

  const Scan& scan() const { return scan_; }
  std::int64_t id() const { return scan_.id; }
  std::size_t next() const { return next_; }
  // Why the run cannot go on (an adaptive loop that cannot run); empty when it can.
  const std::string& failure() const { return failure_; }
  const std::string& prediction_note() const { return prediction_note_; }
  // Nothing left to measure: every point stored, or an adaptive loop with no candidate.
  bool done() const { return next_ >= scan_.points_total || (adaptive_ && !candidate_); }
  bool at_max_points() const { return next_ >= scan_.points_total; }

  // One point, as docs/architecture.md §6 tells it.
  struct Point {
    PointRecord record;
    std::size_t geometry = 0;  // index into the plan's geometries
    Clock::time_point started;
    double device_s = 0, twin_s = 0;  // seconds the devices and the twin took
    PointTiming timing;                // the move's and the reading's share of device_s
  };
  Point begin_point();                                            // the geometry; its prediction asked for
  PointReadings read(Point& pt, PointDevices& d);                  // 3
  void reduce(const PointReadings& in, PointRecord& p);           // 4
  void predict_and_judge(Point& pt);                              // 5
  void commit(const PointRecord& p, const std::string& text);      // 6
  void publish(const std::string& text);                          // 7
  // 8, after the point is stored and published: its divergence alert, the scan's verdict
  // judged again, the adaptive loop told, the progress published. Returns the reason to
  // pause the scan (a sustained divergence with pause_on_sustained), if any.
  std::optional<std::string> after_commit(const Point& pt);

  // Completes the run: the last verdict, an adaptive scan's final loop state. Returns the
  // reason the completed scan carries (empty for a plain scan).
  std::string complete();
  // The run ends in `state` (not completed): an adaptive scan's loop state stored, and a scan
  // ending early judged on the points it has.
  void end(ScanState state, const std::string& actor);
  // The running adaptive scan's loop state; null for a plain scan (any thread).
  nlohmann::json adaptive_status() const;

 private:
  void judge(std::int64_t point_index, bool final);
  void publish_progress();
  void set_adaptive_status(nlohmann::json j);

  RunContext ctx_;
  Scan scan_;
  double tolerance_ = 0;
  std::optional<std::int64_t> sample_id_;
  std::shared_ptr<TwinService::Batch> batch_;
  std::shared_ptr<const ScanTwin> scan_twin_;  // kept for an adaptive scan's per-point batches
  // An adaptive scan: its loop, the candidate of the next point, and whether the loop has
  // started choosing the one after it (a point measured again after a fault does not).
  std::unique_ptr<AdaptiveLoop> adaptive_;
  std::optional<std::size_t> candidate_;
  bool choosing_ = false;
  std::shared_ptr<const twin::Colorimeter> colorimeter_;
  std::string prediction_note_;  // why there are no predictions
  std::string failure_;
  std::string twin_version_;     // of the profile the run started with
  double reference_beta_ = 1.0;  // that profile's β of the reference white
  std::size_t next_ = 0;         // next point index to measure
  std::size_t since_start_ = 0;  // points measured in this run
  ReferenceReadings reference_;  // last read, at reference_.white->integration_ms
  // Where every point's auto-ranging starts, found at the run's first reading; 0: the
  // photometer does not range.
  std::optional<double> nominal_ms_;
  ReferenceDriftMonitor drift_{DivergenceSettings{}.reference_drift};
  ScanEvidence evidence_{0, 2};   // every point of the scan, stored ones included
  std::string spec_;              // the sample's catalogued BSDF
  std::string verdict_stored_;    // decision and cause of the verdict last stored
  double busy_seconds_ = 0;       // wall time of the points of this run (for the ETA)
  bool sustained_raised_ = false;
  std::optional<std::string> pause_;  // a pause the verdict asks for (pause_on_sustained)
  std::size_t since_judged_ = 0;  // points since the verdict was last judged
  mutable std::mutex status_mu_;
  nlohmann::json adaptive_status_;  // under status_mu_
};

}  // namespace gonio::daemon
