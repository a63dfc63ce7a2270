// Sequential design: which candidate geometry an adaptive scan measures next (twin/design.md).
//
// A scan's candidates are its plan's geometries; each is measured at most once. A design is
// fed the points as they are measured and answers, at any moment, the next candidate to
// measure and whether its stopping rule holds.
//
//   ParameterDesign  a model with free parameters ('?' marks, as fit_material): measures
//                    seeds, fits, then picks the candidate that adds most information
//                    about the parameters per second of instrument time (Bayesian
//                    D-optimality on the twin's Jacobian); done when every free
//                    parameter's relative standard uncertainty is at most the target.
//   CurveDesign      no model: refines the measured curves where the interpolated curve is
//                    least certain (the gap between a linear and a cubic interpolant);
//                    done when that estimate is within the tolerance everywhere.
//
// Choosing while the arms move: next() takes the candidates already chosen but not yet
// measured (`pending`). The information a point brings about the parameters depends on
// where it is, not on what it reads (the design is linearised at the current estimate),
// so a pending point is counted before its reading arrives, and the runner can ask for the
// next choice while the current point is being measured.
//
// Not thread-safe: one thread at a time (goniod's adaptive loop owns one on its worker).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "gonio/proto/arms.hpp"
#include "gonio/proto/geometry.hpp"
#include "gonio/proto/scan.hpp"
#include "gonio/proto/spectrum.hpp"
#include "gonio/twin/fit.hpp"
#include "gonio/twin/instrument.hpp"

namespace gonio::twin {

// How long the instrument takes per point: the arms move one after the other at a finite
// speed, settle, and the photometer reads the dark, the white and the sample.
struct ScanTiming {
  double speed_deg_s = 20;  // per arm (the mock's default; a GCMS-4 arm is slower)
  double settle_s = 0.2;    // after any move
  double reading_s = 2;     // per point, all wavelengths
  // Throws Error naming the field (speed 0.1–1000 °/s, settle 0–60 s, reading 0–3600 s).
  void validate() const;
  double move_s(const Geometry& from, const Geometry& to) const;
  double point_s(const Geometry& from, const Geometry& to) const { return move_s(from, to) + reading_s; }
  // A whole sequence of geometries, from the arms at `start`.
  double total_s(const Geometry& start, const std::vector<Geometry>& sequence) const;
};

// The instrument's own timing, learnt from a run's points: each point's move (its travel,
// summed over the axes, and the seconds from the first command to the end of settling) and
// its reading (the seconds from the dark to the sample, the white when due and the
// autoranger's retries included). Moves are fitted by least squares to seconds = settle +
// travel / speed; readings by their median. Until it has seen enough (two moves of
// different travel; one reading) a value stays at the prior's.
class TimingRecord {
 public:
  void move(double travel_deg, double seconds);
  void reading(double seconds);
  // The timing learnt, the prior's where not learnt yet, clamped to ScanTiming's ranges
  // (arms that take no time, as the mock's at time_scale 0, learn the fastest speed).
  ScanTiming timing(const ScanTiming& prior) const;
  std::size_t moves() const noexcept { return travel_.size(); }
  std::size_t readings() const noexcept { return reading_s_.size(); }
  // Seconds spent on the points recorded: moves and readings, as measured.
  double seconds() const noexcept { return total_s_; }

 private:
  std::vector<double> travel_, move_s_, reading_s_;
  double total_s_ = 0;
};

// Where the arms can go, by the motion guard's rule (proto/arms.hpp) with the profile's
// clearance: a geometry that keeps arms.min_separation_deg and lies on the arms' side of the
// collision zone — the side of the profile's calibration geometry (0°/45°), where the arms
// read the white standard. goniod's plan check refuses the rest; the planners never propose it.
struct ArmReach {
  explicit ArmReach(const InstrumentProfile& profile);
  ArmClearance clearance;
  Geometry calibration;      // the profile's calibration geometry
  std::optional<long> side;  // its side; nullopt: it is inside the zone (any side)
  bool reaches(const Geometry& g) const;
  // Why not (empty when it does), in goniod's words.
  std::string why_not(const Geometry& g) const;
  // Throws Error(plan_rejected) naming `field`[k] and the geometry of the first candidate
  // the arms cannot reach; with no side of its own, the first candidate's is taken.
  void check(const std::vector<Geometry>& candidates, std::string_view field = "candidates") const;
};

enum class DesignState { running, target_reached, max_points };
inline constexpr EnumNames<DesignState, 3> kDesignStateNames{{
    {DesignState::running, "running"},
    {DesignState::target_reached, "target_reached"},
    {DesignState::max_points, "max_points"},
}};
constexpr const auto& enum_names(DesignState) { return kDesignStateNames; }  // proto/enum_text.hpp

struct EstimatedParameter {
  std::string name;
  double value = 0;
  double u = 0;  // standard uncertainty (k = 1), from the latest fit
};

// What an adaptive scan shows (scan.get's `adaptive`).
struct DesignStatus {
  AdaptiveMode mode = AdaptiveMode::parameters;
  DesignState state = DesignState::running;
  std::size_t points_used = 0;
  std::vector<EstimatedParameter> parameters;  // parameters mode, after the first fit
  std::optional<double> estimated_error;       // curve mode: max over the candidates
  std::optional<double> chi2_per_dof;          // parameters mode
  bool misfit = false;                          // χ²/dof above the fit's misfit limit
  std::vector<std::string> warnings;
  // Instrument time (goniod's loop): the timing the choices are priced with (learnt from
  // the run), the seconds the points took as measured, and what a uniform scan of every
  // candidate in list order would take by that timing.
  struct Time {
    ScanTiming timing;
    std::size_t moves_timed = 0, readings_timed = 0;
    double seconds = 0;          // the points' moves and readings, measured
    double waiting_seconds = 0;  // the arms idle for a choice
    double uniform_seconds = 0;  // every candidate once, by `timing`
  };
  std::optional<Time> time;
  nlohmann::json to_json() const;
};

class Design {
 public:
  virtual ~Design() = default;
  const std::vector<Geometry>& candidates() const noexcept { return candidates_; }
  // The candidates measured first, before any choice (in measuring order).
  virtual std::vector<std::size_t> seeds() const = 0;
  // A measured point of candidate `c` (its nominal geometry is the candidate's).
  virtual void add(std::size_t c, const MeasuredPoint& p) = 0;
  // Brings the estimate up to date with every point added (parameters mode: a refit).
  virtual void update() = 0;
  // The candidate to measure next, the arms standing at `arms` after the pending points;
  // nullopt when no candidate is left worth measuring, or when the points in hand and
  // pending are expected to reach the target: the caller then adds the pending points,
  // updates, and asks again unless target_reached(). Uses the estimate of the last update.
  virtual std::optional<std::size_t> next(const std::vector<std::size_t>& pending,
                                          const Geometry& arms) const = 0;
  // The stopping rule held at the last update.
  virtual bool target_reached() const = 0;
  virtual DesignStatus status() const = 0;
  std::size_t measured() const noexcept { return measured_.size(); }
  // Readings of candidate c so far, and how many one candidate may have.
  int readings(std::size_t c) const;
  int max_readings() const noexcept { return max_readings_; }
  // Whether c may be chosen with `pending` chosen before it.
  bool available(std::size_t c, const std::vector<std::size_t>& pending) const;
  // Restricts next() to the moves the instrument can make from where the arms stand (the
  // motion guard's rule); by default every move is allowed.
  using Movable = std::function<bool(const Geometry& from, const Geometry& to)>;
  void set_movable(Movable m) { movable_ = std::move(m); }
  // The timing the choices are priced with (ScanTiming's defaults until the run's own).
  virtual void set_timing(const ScanTiming& t) = 0;

 protected:
  Design(std::vector<Geometry> candidates, int max_readings);
  void mark(std::size_t c);  // throws for an unknown candidate or one read max_readings times
  std::vector<Geometry> candidates_;
  std::vector<std::size_t> measured_;  // in the order measured (a candidate read again recurs)
  std::vector<int> readings_;
  int max_readings_ = 1;
  Movable movable_;
  bool movable(const Geometry& from, std::size_t c) const { return !movable_ || movable_(from, candidates_[c]); }
};

struct ParameterDesignOptions {
  double target_rel_u = 0.05;
  // Readings of one candidate: reading the most informative geometries again is what an
  // optimal design does; the cap keeps it spread, so that a model that misses at one
  // geometry cannot take the whole scan there.
  int max_readings = 3;
  ScanTiming timing;
  FitOptions fit;                      // the refits (warm started from the last one)
  std::uint64_t jacobian_samples = 1u << 12;  // per candidate, for the information
  int jacobian_replicates = 8;
  unsigned threads = 0;                // 0: all cores
  // The model's own uncertainty, relative to β, by region: how far a real sample may depart
  // from the model there. It weighs where to measure (the choice's information), not the
  // fit: u_model/β = near_specular + per_10deg × |aspecular|/10°, times grazing_factor where
  // θr ≥ grazing_deg (a lobe's tail: where real samples depart most from microfacet models
  // and the footprint is largest). 0 everywhere: the model is taken as exact.
  struct ModelTrust {
    double near_specular = 0.002;
    double per_10deg = 0.002;
    double grazing_deg = 70;
    double grazing_factor = 3;
    double relative_u(const Geometry& g) const;
  } model_trust;
  // The seeds' coverage: no seed's cell (the candidates nearer that seed than any other, in
  // list order) may give more than this share of the information about the parameters
  // (trace(F⁻¹ F_cell) / P over the points measured and pending) while another cell can
  // still be chosen, so that no one region — a lobe's tail — determines them alone. 1: off.
  double max_cell_share = 0.5;
  // Once the refit shows that the model misses (χ²/dof above fit.misfit_limit), its
  // information says where the model is sensitive, not where the sample is described, and
  // a fitted parameter means whatever the chosen geometries weigh it to mean. The choice
  // then fills the widest gaps among the candidates instead (twin/design.md), so that the
  // points tend to the uniform scan's and so does the estimate. false: the model's
  // information throughout.
  bool spread_on_misfit = true;
  void validate() const;
};

class ParameterDesign final : public Design {
 public:
  // `model` a spec with '?' marks; throws Error(invalid_argument) naming `model` for one the
  // twin cannot build, and for a bad option.
  ParameterDesign(std::string model, std::vector<Geometry> candidates, WavelengthGrid grid,
                  InstrumentProfile profile, ParameterDesignOptions options);
  std::vector<std::size_t> seeds() const override;
  void add(std::size_t c, const MeasuredPoint& p) override;
  void update() override;
  std::optional<std::size_t> next(const std::vector<std::size_t>& pending,
                                  const Geometry& arms) const override;
  bool target_reached() const override;
  DesignStatus status() const override;
  // The latest fit (none before the first update with enough points).
  const std::optional<FitResult>& fit() const noexcept { return fit_; }
  // The current estimate of the free parameters (the template's starts before any fit).
  const std::vector<double>& estimate() const noexcept { return x_; }
  void set_timing(const ScanTiming& t) override { options_.timing = t; }

 private:
  void linearise();  // candidates' Jacobians and predicted β at x_
  double log_det_gain(const std::vector<double>& info_inv, std::size_t c) const;
  // F⁻¹ of the points measured and `extra` with the prior: by the choice's weights (the
  // readings' u and the model's own), or by the readings' u alone (what the fit will say).
  std::vector<double> information(const std::vector<std::size_t>& extra, bool readings_only = false) const;
  // The information of the points measured and pending by seed cell, their sum with the
  // prior, and the cell that gives the largest share (parameter_design.cpp).
  struct Coverage;
  Coverage coverage(const std::vector<std::size_t>& pending) const;
  // Whether adding c keeps the dominant cell within max_cell_share of the information.
  bool keeps_coverage(const Coverage& cov, std::size_t c) const;
  // The choice once the model is seen to miss: the candidate farthest from every point in hand.
  std::optional<std::size_t> widest_gap(const std::vector<double>& info_inv, const std::vector<std::size_t>& pending,
                                        const Geometry& arms) const;

  std::string model_;
  WavelengthGrid grid_;
  InstrumentProfile profile_;
  ParameterDesignOptions options_;
  std::unique_ptr<ModelTemplate> tmpl_;
  MeasuredData data_;
  std::vector<double> x_;                 // current estimate
  std::optional<FitResult> fit_;
  std::string note_;                      // why the last refit failed
  std::vector<std::vector<double>> jac_;  // per candidate: channels × parameters, row-major
  std::vector<std::vector<double>> beta_; // per candidate: predicted β
  std::vector<std::vector<double>> w_;    // per candidate: 1/(u² + u_model²) per channel, the choice's
  std::vector<std::vector<double>> w_read_;  // per candidate: 1/u² (the readings' u alone)
  std::vector<std::size_t> cell_;         // per candidate: its seed's cell
  std::vector<double> prior_;             // prior precision per parameter (diagonal)
};

struct CurveDesignOptions {
  // Relative to the curve: to max(|β|, floor × the curve's peak) per channel, as
  // `gonio-twin plan` measures it, so that tails far below the lobe count absolutely.
  double tolerance = 0.01;
  double floor = 0.01;
  ScanTiming timing;
  // Seeds: both ends, the specular direction and points at most this far apart.
  double seed_spacing_deg = 10;
  // The readings' own noise is no interpolation error: a gap below k·u is not refined.
  double coverage_k = 2;
  // The higher-order interpolant is not exact either: the estimate is this multiple of the
  // difference (the coverage of the estimate is tested against dense curves,
  // tests/unit/twin/design/curve_design_test.cpp).
  double safety = 1.5;
  void validate() const;
};

class CurveDesign final : public Design {
 public:
  CurveDesign(std::vector<Geometry> candidates, CurveDesignOptions options);
  std::vector<std::size_t> seeds() const override;
  void add(std::size_t c, const MeasuredPoint& p) override;
  void update() override;
  std::optional<std::size_t> next(const std::vector<std::size_t>& pending,
                                  const Geometry& arms) const override;
  bool target_reached() const override;
  DesignStatus status() const override;
  // The interpolated curve at candidate c, per channel: the local cubic (in log β where
  // positive) through its measured neighbours along its curve; the measurement itself where
  // measured. Empty when c has no measured point on either side.
  std::vector<double> interpolate(std::size_t c) const;
  void set_timing(const ScanTiming& t) override { options_.timing = t; }

 private:
  struct Curve {
    std::vector<std::size_t> members;  // candidate indices by receiving angle
  };
  struct Estimate {
    std::vector<double> value;  // delivered, per channel
    double error = 0;           // relative, over the channels
  };
  std::optional<Estimate> estimate(std::size_t c) const;
  CurveDesignOptions options_;
  std::vector<Curve> curves_;
  std::vector<std::size_t> curve_of_, position_;  // per candidate
  std::vector<MeasuredPoint> points_;             // per candidate (empty: not measured)
  std::vector<double> error_;
  double max_error_ = 1e300;
};

// The offline study behind `gonio-twin design`: a virtual sample (`truth`) measured with
// Gaussian noise u = √((rel·β)² + abs²) through the twin, once on every candidate (the
// uniform grid, fitted) and once adaptively; what each costs and what it determines.
struct DesignStudyOptions {
  std::string truth;     // the virtual sample; empty: the model at its start values
  double noise_rel = 0.005, noise_abs = 0.0005;
  // The noise an instrument actually has: each candidate's u per channel taken from these
  // points of a scan over the same candidates (the point at the candidate's geometry,
  // resampled to the grid), instead of noise_rel and noise_abs. A like-for-like study of
  // goniod's loop on that instrument.
  std::optional<MeasuredData> noise_of;
  std::uint64_t seed = 1;
  int max_points = 50;
  ParameterDesignOptions parameters;
  CurveDesignOptions curve;
  EstimatorOptions measurement;  // the virtual instrument's own estimator
};
struct DesignRun {
  std::vector<std::size_t> chosen;  // candidate indices in measuring order
  double seconds = 0;               // instrument time by the timing model
  DesignStatus status;
  double choice_seconds_max = 0;    // wall time of the slowest update + next
};
struct DesignStudy {
  DesignRun uniform, adaptive;
  // Curve mode: the interpolated adaptive curve against the uniform (dense) measurement and
  // against the noise-free truth: max relative error over candidates and channels, beyond
  // the readings' k·u, relative as the tolerance (CurveDesignOptions::floor).
  std::optional<double> error_vs_dense, error_vs_truth;
  nlohmann::json to_json(const std::vector<Geometry>& candidates) const;
};
// `model` empty: curve mode. Throws Error naming the field for bad input, and
// Error(plan_rejected) for a candidate the arms cannot reach (ArmReach::check), as goniod would.
DesignStudy study_design(const std::string& model, const std::vector<Geometry>& candidates,
                         const WavelengthGrid& grid, const InstrumentProfile& profile,
                         const DesignStudyOptions& options);

}  // namespace gonio::twin
