// Diagnosis of a sustained divergence (docs/architecture.md §6, step 8): the inverse-twin
// refit of the cause a scan's verdict names.
//
// The verdict (verdict.hpp) names its cause from a model linear in each candidate, refitted
// after every point. When a scan whose verdict raised the sustained alert ends, the Diagnoser
// refits that one parameter through the inverse twin on the whole scan — nonlinear, the
// instrument simulated: fit_material for a parameter of the sample's BSDF, calibrate for an
// instrument input — stores the fit with the scan (kind "diagnosis") and appends the refined
// value to the alert. It runs on a thread of its own, so neither the runner nor an RPC worker
// waits for it. A verdict that names no cause (too few points, a tie) is not refitted.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "gonio/proto/point.hpp"
#include "gonio/twin/fit.hpp"

namespace gonio::daemon {

class AlertService;
class Store;
class TwinService;

// The calibrate parameter of a verdict's instrument input ("receive_arm_deg" →
// "receive_offset_deg"); nullopt for one calibrate does not fit.
std::optional<std::string> calibration_parameter(const std::string& verdict_parameter);
// `spec` with its parameter `name` (as spec_parameters names it) marked free ('?'), started at
// its catalogued value; nullopt when the spec has no such parameter.
std::optional<std::string> fit_template(const std::string& spec, const std::string& name);

class Diagnoser {
 public:
  Diagnoser(Store& store, TwinService& twin, AlertService& alerts);
  ~Diagnoser();  // finishes the running diagnosis, drops queued ones
  Diagnoser(const Diagnoser&) = delete;
  Diagnoser& operator=(const Diagnoser&) = delete;

  // Queues a diagnosis of scan `scan_id` for alert `alert_id`; returns at once. A scan
  // already queued is not queued twice.
  void request(std::int64_t scan_id, std::int64_t alert_id);

 private:
  struct Job {
    std::int64_t scan_id = 0, alert_id = 0;
  };
  void work();
  void diagnose(const Job& job);

  Store& store_;
  TwinService& twin_;
  AlertService& alerts_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<Job> queue_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace gonio::daemon
