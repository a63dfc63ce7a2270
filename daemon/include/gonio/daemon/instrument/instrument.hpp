// Instrument — the scheduler and scan runner on the instrument's own thread (docs/architecture.md §5).
//
// One thread owns the drivers (they may block). It runs manual commands (home, move, reset)
// when no scan is running, and otherwise measures one point per loop turn:
//   move the arms (the order that keeps them clear of each other) → settle → dark →
//   reference white (per the plan's reference mode) → sample → read the arms back →
//   β = β_ref (S − D) / (R − D_R) with first-order uncertainty → wait for the twin's
//   prediction (computed ahead by TwinService) → divergence tests → commit the point →
//   alerts and notifications.
// The point is committed before the next move, so a crash loses at most the point being
// measured, and a restart resumes at the next unmeasured point (Store::next_point_index).
//
// Devices come back: a device call that fails on its link (disconnected, io_error) drops
// that device (motion controller or photometer), and the runner opens it again through the
// registry's InstrumentOpener — the motion controller under the same guard, the mock on the
// same lab — after reconnect_initial, doubling the wait after every failed attempt up to
// reconnect_max. A motion controller that comes back may have lost its position (a
// stepper controller that rebooted), so after such a reconnection no arm moves and no scan
// starts until every axis has been homed (instrument.home). status() shows each device's
// link, last error and next retry.
//
// Scheduling: interrupted scans first, then queued scans in queue order whose not-before
// time has passed. A device fault pauses the scan (reason in its state), raises a critical
// alert and latches the instrument: nothing else starts until a technician resumes a scan
// or resets the instrument (or auto-resume, when configured, does it). The latch survives
// a crash, an OOM kill or an upgrade: it is rebuilt at start from the device_fault alerts
// nobody has acknowledged, and resuming or resetting acknowledges them. instrument.stop
// stops the arms at once from any thread and pauses the running scan.
//
// Every change of a scan's state goes through one private member, transition(), which
// words the reason once, stores it and publishes the stored record, so that scan.state
// notifications always say what scan.get says.
//
// The instrument is cut by concern: instrument.cpp (thread, loop, devices, status),
// instrument/run.cpp (starting and finishing a run, one point's steps in order and the one
// fault rule for them, device and storage faults), instrument/commands.cpp (pause, resume,
// cancel, the state transition, plan checks and the manual commands). Its parts have their
// own types: ScanRun (scan_run.hpp: a run's state and the point steps of
// docs/architecture.md §6), StorageWatch (storage_watch.hpp), AutoRanger (auto_ranger.hpp:
// the ranging loop; autorange.hpp the rule) and ArmMover (arm_moves.hpp: the order of arm
// moves and of homing). The arithmetic of a point is in point_reduction.hpp, the plan rules
// in plan_check.hpp.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "gonio/daemon/config/config.hpp"
#include "gonio/daemon/instrument/alerts.hpp"
#include "gonio/daemon/instrument/arm_moves.hpp"
#include "gonio/daemon/instrument/auto_ranger.hpp"
#include "gonio/daemon/instrument/divergence.hpp"
#include "gonio/daemon/instrument/plan_check.hpp"
#include "gonio/daemon/instrument/storage_watch.hpp"
#include "gonio/daemon/instrument/twin_service.hpp"
#include "gonio/daemon/rpc/hub.hpp"
#include "gonio/daemon/store/store.hpp"
#include "gonio/drivers/motion/collision.hpp"
#include "gonio/drivers/motion/motion_controller.hpp"
#include "gonio/drivers/photometer/photometer.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::drivers {
class InstrumentOpener;
}

namespace gonio::daemon {

class ScanRun;
class PointFault;
struct RunContext;

class Instrument {
 public:
  Instrument(const Config& config, Store& store, TwinService& twin, AlertService& alerts, Hub& hub);
  ~Instrument();
  Instrument(const Instrument&) = delete;
  Instrument& operator=(const Instrument&) = delete;

  void start();
  // The scans a crash left running could not be marked interrupted (the store cannot
  // write): done with `reason` once it can. Call before start().
  void recover_when_writable(std::string reason) { storage_.recover_when_writable(std::move(reason)); }
  // Finishes the point in progress, parks the running scan as `interrupted` and joins the
  // thread. Idempotent.
  void shutdown();

  // ---- scheduler (any thread)
  void wake();
  Scan pause(std::int64_t scan, const std::string& actor, const std::string& reason);
  Scan resume(std::int64_t scan, const std::string& actor);
  Scan cancel(std::int64_t scan, const std::string& actor, const std::string& reason);
  std::optional<std::int64_t> running_scan() const;
  // The running adaptive scan's loop state (scan.get's `adaptive`); nullopt for any other
  // scan, whose last state is stored with it (kind "adaptive").
  std::optional<nlohmann::json> adaptive_status(std::int64_t scan) const;
  // Throws Error(plan_rejected) naming the geometry ("geometries[12]") and the limit.
  void validate_plan(const ScanPlan& plan) const;

  // ---- instrument commands (block the calling thread until done)
  nlohmann::json status() const;
  nlohmann::json home(std::vector<drivers::Axis> axes, const std::string& actor);
  nlohmann::json move(const std::map<drivers::Axis, double>& targets, const std::string& actor);
  nlohmann::json reset(const std::string& actor);
  // Any thread, immediate: stops every axis and pauses the running scan.
  nlohmann::json stop(const std::string& actor);

  // Runner statistics for system.info, as JSON object text: points measured since start and
  // the daemon's own time per point (excluding motion, photometer and twin), in ms.
  std::string stats_text() const;
  // Last sign of progress of the runner thread: a turn of its loop or the start of a device
  // call or of a wait for the twin (for the systemd watchdog).
  std::chrono::steady_clock::time_point heartbeat() const;
  // Called with a one-line status on scan transitions (sd_notify STATUS). Set before start().
  void set_status_listener(std::function<void(const std::string&)> f) {
    status_listener_ = std::move(f);
  }
  // Called from the runner thread with (scan, alert) when a scan ends with a verdict that
  // raised the sustained-divergence alert and names a cause (the diagnosis refits it); must
  // return at once. Set before start().
  void set_sustained_listener(std::function<void(std::int64_t, std::int64_t)> f) {
    sustained_listener_ = std::move(f);
  }

 private:
  struct Command {
    std::function<nlohmann::json()> fn;
    std::promise<nlohmann::json> done;
    bool needs_devices = true;
  };

  enum class Side { motion, photometer };
  // One device's link, for status() and the reconnection back-off (under mu_).
  struct Link {
    bool up = false;
    bool ever_up = false;   // opened once: a later open is a reconnection
    std::string error, errc, error_at;  // the last failure (message, Errc id, UTC)
    std::optional<std::chrono::steady_clock::time_point> next_retry;
    std::chrono::milliseconds wait{0};  // before the attempt after next_retry, if it fails
    int failures = 0;                   // failed opens since the link was last up
    std::uint64_t reconnects = 0;
  };

  void loop();
  // Opens every side that is down and due. `at_start`: a configuration error throws.
  void open_devices(bool at_start = false);
  void open_side(Side s, bool at_start);
  // A device call failed on its link: the device is closed and reopened later (runner thread).
  void drop_device(Side s, const Error& e);
  Link& link(Side s) { return links_[static_cast<int>(s)]; }
  const Link& link(Side s) const { return links_[static_cast<int>(s)]; }
  nlohmann::json link_json(Side s) const;  // under mu_
  Error devices_down() const;              // under mu_: which device is missing, and why
  void start_run(const Scan& scan);
  // One point of the current run: docs/architecture.md §6 steps 3–8, ScanRun's steps in
  // order. A step's PointFault is acted on here, by the one rule of §6 (on_point_fault).
  void step();
  void on_point_fault(const PointFault& f);
  void finish_run(ScanState state, const std::string& reason, const std::string& actor);
  // The stored scan; throws Error::not_found("scan", ...).
  Scan stored_scan(std::int64_t id) const;
  // The one place a scan changes state: words the reason (an empty `reason` becomes "paused
  // by <actor>", "cancelled by <actor>" or "resumed by <actor>" for those states), stores it
  // and publishes scan.state with the stored state and reason. Returns the stored scan.
  // Callers hold sched_mu_.
  Scan transition(std::int64_t id, ScanState to, const std::string& reason,
                  const std::string& actor);
  // A scan that has ended (completed, failed, cancelled): its standing sustained divergence
  // alerts that its last stored verdict no longer supports are resolved (alerts.hpp,
  // sustained_resolution). Called by transition().
  void resolve_unsupported_alerts(std::int64_t scan);
  DeviceFacts device_facts() const;  // for check_plan
  void on_device_fault(const Error& e);
  // The store did not take the point (Error(storage_unavailable): it cannot write): the
  // scan pauses with a critical `storage` alert, written from the store's reserve or held in
  // memory (storage.hpp).
  void on_storage_fault(const Error& e);
  // From the loop (StorageWatch::poll, at most once a second): the low-space warning, a
  // read-only store's probe, and what waited for the store to write again. Runner thread.
  void check_storage();
  // The fault latch outlives the process: at start it is rebuilt from the unacknowledged
  // device_fault alerts, and a technician's resume or reset acknowledges them.
  void restore_fault_latch();
  void acknowledge_faults(const std::string& actor);
  // Runs `fn` on the runner thread. `needs_devices`: refused while a device is down.
  nlohmann::json submit(std::function<nlohmann::json()> fn, bool needs_devices = true);
  void set_state(std::string state, std::string detail = {});
  void settle_state(std::string detail = {});  // "fault" while latched, else "idle"
  void publish_state();
  void beat();
  AxisPositions positions() const;  // a copy, under mu_
  nlohmann::json positions_json() const;
  // Runs one turn of the loop with a run in place (a requested pause or cancel, else a
  // point). Called without mu_.
  void run_turn();
  // No run: a due auto-resume or the next runnable scan. Whether one was started.
  bool start_next();
  // After a turn's point: complete the run, or carry out the pause the verdict asks for.
  void after_point(const std::optional<std::string>& pause);
  RunContext run_context();

  const Config& config_;
  Store& store_;
  TwinService& twin_;
  AlertService& alerts_;
  Hub& hub_;
  DivergenceSettings divergence_;
  drivers::MotionGuard guard_;

  // Owned by the runner thread; the pointers themselves are read by stop() under mu_.
  std::unique_ptr<drivers::MotionController> motion_;
  std::unique_ptr<drivers::Photometer> photometer_;

  // Lock order: sched_mu_ (scan state transitions) before mu_ (the runner's state).
  mutable std::mutex sched_mu_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::function<void(const std::string&)> status_listener_;
  std::function<void(std::int64_t, std::int64_t)> sustained_listener_;
  std::thread thread_;
  bool stopping_ = false;
  bool started_ = false;
  std::deque<std::shared_ptr<Command>> commands_;
  std::unique_ptr<ScanRun> run_;
  std::optional<std::int64_t> running_;
  enum class Control { none, pause, cancel };
  std::optional<Scan> control_running(std::int64_t id, Control what, const std::string& reason,
                                      const std::string& actor, std::unique_lock<std::mutex>& sched);
  Control control_ = Control::none;
  std::string control_reason_, control_actor_;
  bool fault_latched_ = false;
  std::string fault_reason_;
  std::optional<std::pair<std::int64_t, std::chrono::steady_clock::time_point>> auto_resume_;
  std::map<std::int64_t, int> auto_resumes_;
  StorageWatch storage_;  // runner thread
  AutoRanger ranger_;     // runner thread
  ArmMover arms_;         // runner thread
  std::string state_ = "starting", state_detail_;
  std::unique_ptr<drivers::InstrumentOpener> opener_;
  Link links_[2];
  std::vector<drivers::Axis> unhomed_;  // to home before any move: the controller reconnected
  // Cached device facts (under mu_).
  std::vector<drivers::Axis> axes_;
  std::map<drivers::Axis, double> positions_;
  std::optional<WavelengthGrid> photometer_grid_;
  std::string photometer_identity_;
  std::atomic<std::int64_t> heartbeat_ns_{0};
  // Statistics (under mu_).
  std::uint64_t points_measured_ = 0;
  std::deque<double> overhead_ms_;  // the last 1000 points
  mutable std::optional<std::pair<std::uint64_t, std::string>> stats_cache_;  // per points_measured_
};

}  // namespace gonio::daemon
