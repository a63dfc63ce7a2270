// AdaptiveLoop — an adaptive scan's choices, made by the twin while the arms work
// (twin/design.md; docs/architecture.md §6).
//
// The runner asks for the candidate of each point. While point k is measured, the loop's
// own thread gives the design the points committed so far, refits (parameters mode) and
// chooses point k + 1 with point k counted as pending (its information does not depend on
// its reading), so the choice is ready when the arms are. Only when the design has nothing
// to choose before point k's reading is in (it expects the target to be reached) does the
// runner wait for one refit. A restart replays the stored points into a new design: the
// loop resumes from them, not from memory.
#pragma once

#include <cstddef>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "gonio/proto/point.hpp"
#include "gonio/proto/scan.hpp"
#include "gonio/twin/design.hpp"
#include "gonio/twin/instrument.hpp"

namespace gonio::daemon {

// What one point cost the instrument: its move (the travel summed over the axes; the
// seconds to the end of settling) and its reading (dark, white when due, sample).
struct PointTiming {
  double travel_deg = 0, move_s = 0, reading_s = 0;
};

class AdaptiveLoop {
 public:
  // Whether the arms can go from one geometry to another (the motion guard's rule).
  using Reachable = std::function<bool(const Geometry&, const Geometry&)>;

  // Throws Error(invalid_argument) naming `adaptive.model` for a model the twin cannot build.
  AdaptiveLoop(const ScanPlan& plan, const twin::InstrumentProfile& profile, Reachable reachable);
  ~AdaptiveLoop();
  AdaptiveLoop(const AdaptiveLoop&) = delete;
  AdaptiveLoop& operator=(const AdaptiveLoop&) = delete;

  // Checks an adaptive plan's model at submission (no twin run). Throws as the constructor.
  static void check(const ScanPlan& plan);

  // The points stored before a restart, in measuring order (blocking: one refit).
  void restore(const std::vector<PointRecord>& points);
  // The candidate of the first point of this run, the arms standing at `arms` (unknown:
  // where the last point left them, else at the first seed); nullopt: nothing left to
  // measure.
  std::optional<std::size_t> first(const std::optional<Geometry>& arms);
  // Point of candidate `c` is being measured: starts choosing the one after it.
  void measuring(std::size_t c);
  // Point of candidate `c` is stored; `t` what it took, from which the loop learns the
  // instrument's timing and prices the next choices with it.
  void committed(std::size_t c, const PointRecord& p, const PointTiming& t);
  // The choice after `c` (measuring(c) first); nullopt: the loop is done.
  std::optional<std::size_t> next_after(std::size_t c);
  // The readings of candidate c so far, this one included once measuring(c) was called.
  int readings(std::size_t c) const { return c < counts_.size() ? counts_[c] : 0; }
  // The latest status; `final` brings the design up to date first and sets the end state.
  twin::DesignStatus status() const;
  twin::DesignStatus finish(bool at_max_points);

 private:
  void catch_up();  // under mu_: queued points into the design, and an update
  std::optional<std::size_t> choose(const std::vector<std::size_t>& pending, const Geometry& arms);
  twin::DesignStatus timed(twin::DesignStatus s) const;  // under mu_: with the time report

  std::vector<std::size_t> seeds_;
  std::size_t taken_ = 0;  // points chosen so far (restored ones included)
  std::optional<std::size_t> last_;  // the candidate measured last: where the arms are
  std::vector<int> counts_;          // readings per candidate (the runner's thread only)
  Reachable reachable_;
  mutable std::mutex mu_;  // the design and the queue
  std::unique_ptr<twin::Design> design_;
  std::vector<std::pair<std::size_t, twin::MeasuredPoint>> queued_;
  twin::DesignStatus status_;
  twin::ScanTiming prior_;      // ScanTiming's defaults: what the choices start with
  twin::TimingRecord timing_;   // this run's points (not those before a restart)
  double waiting_s_ = 0;        // the runner waiting for a choice
  double first_move_s_ = 0;     // to this run's first point
  std::future<std::optional<std::size_t>> job_;
};

}  // namespace gonio::daemon
