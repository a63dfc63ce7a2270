// Diagnosis of a sustained divergence (docs/architecture.md §6): when a scan's points keep
// disagreeing with the twin, the inverse twin tries the instrument parameters that most
// often go wrong — an arm offset, the reference white's gain — one at a time on the scan's
// measured points, and the alert says which one explains the disagreement, or that none does
// (then the sample itself likely differs from its reference BSDF).
//
// explain() is the pure decision; Diagnoser runs the fits on a thread of its own, so neither
// the runner nor an RPC worker waits for them, stores the result with the scan (a fit of
// kind "diagnosis") and appends the verdict to the alert.
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

// The single-parameter explanations tried, in this order.
const std::vector<std::string>& diagnosis_parameters();

// χ²/dof of the stored measured against predicted β (u and the twin's s.e. in quadrature) over
// the points with a prediction; nullopt when there is none.
std::optional<double> chi2_per_dof(const std::vector<PointRecord>& points);

struct Verdict {
  bool explained = false;
  std::optional<std::size_t> best;   // index into the candidates
  std::vector<std::size_t> alike;    // others that explain it as well (not separable)
  std::string text;                  // one sentence for the alert
};

// A candidate explains the divergence when its fit is usable (converged, off its bounds,
// identifiable, with an uncertainty narrower than its range), brings χ²/dof to at most
// kExplainedChi2 and to at most a quarter of `before`. A fit on its bound never explains, but
// when it fits best the text says so. `candidates[i]` fitted diagnosis_parameters()[i] alone.
inline constexpr double kExplainedChi2 = 2.0;
Verdict explain(double before, const std::vector<twin::FitResult>& candidates);

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
