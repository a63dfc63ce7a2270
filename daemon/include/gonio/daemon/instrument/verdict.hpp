// ScanEvidence — the whole scan as evidence (docs/architecture.md §6, docs/decision-rule.md).
//
// A consistent small shift is invisible per point and obvious over a scan. Every point adds
// its residuals r = m − p per channel, weighted by 1/v with v = u_m² + s_p² + the budget's
// random components (repeatability, lamp), and the columns of a linear model of what could
// have caused them: the instrument's systematic inputs (arm offsets, aperture scales, the
// white's gain: the budget's sensitivities) and each numeric parameter of the sample's
// catalogued BSDF (ScanTwin's sensitivities). The normal equations are accumulated, so a
// verdict after each point costs a few small solves.
//
// An arm offset enters with its curvature and the arms' interaction (β at a glossy peak is
// not linear over a degree):
// the fits are Gauss–Newton iterations, each a small solve.
//
// Hypotheses, each a generalised least-squares fit with the instrument's inputs held to
// their datasheet priors (N(0, u²), and within ±the stated limit for a rectangular one):
//   H0            the sample as catalogued, the instrument within its datasheet;
//   instrument j  arm offset or white gain j free (its prior dropped; the apertures are
//                 always held to theirs);
//   sample k      parameter k free.
// The best candidate must improve χ² on H0 by kSignificant to be evidence at all, and beat
// the next by kTie to be named. Then:
//   instrument j, |θ̂| − k·u > its datasheet limit       instrument_out_of_spec
//   sample k, its effect on β judged point by point     out_of_tolerance / agrees / undecided
//   nothing significant (or an in-spec instrument input)  the per-band mean relative difference
//                 with its uncertainty (random and systematic) judged against the tolerance
// A candidate whose fitted change lies beyond the range where its linearisation holds (a few
// finite-difference steps; a sample parameter that would change sign or more than double) is
// not evidence. Fewer points than twice the candidates: the per-band test alone, never a
// cause; fewer than three: undecided.
//
// A spectral parameter's nodes are also tried as contiguous bands moving together and as the
// whole spectrum scaled (one free scale each); a catalogue with no parameter at all (a master,
// a table) is tried as its β scaled over contiguous wavelength bands and over the whole
// spectrum, named `catalogue@LO-HI`. Such a scale is exactly what a reference-white gain
// does: the two tie, and the verdict says so. A cause is named only when it explains: the χ²
// left after it must be consistent with its degrees of freedom (p ≥ kConsistent). When no
// candidate explains the residuals, either they are random — point-to-point scatter along the
// arms' sensitivity beyond the stated repeatability, named as the instrument's
// `position_repeatability_deg` (a calibration hint) — or the sample does not match its
// catalogue in a way no single parameter describes: no cause, `explained` false, the worst
// regions listed, and the decision from the bands and regions judged with the misfit in
// their uncertainty.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "gonio/daemon/instrument/divergence.hpp"
#include "gonio/proto/point.hpp"

namespace gonio::daemon {

struct VerdictCause {
  std::string kind;       // "sample" or "instrument"
  std::string parameter;  // "conductor.alpha", "lambert.albedo@600-700", "receive_arm_deg", ...
  double value = 0, u = 0, nominal = 0;
  // A band of a spectral parameter's nodes moving together: the nodes' span and the fitted
  // ratio to the catalogue (value and nominal are then that scale and 1).
  std::optional<std::array<double, 2>> band_nm;
};

// Where the residuals left by the verdict's fit are largest: points grouped by incidence and
// aspecular angle (10° bins).
struct MisfitRegion {
  double theta_i = 0;
  double aspecular_lo = 0, aspecular_hi = 0;  // θi − θr, degrees
  std::size_t points = 0;
  double chi2_per_n = 0;   // χ² per channel left there
  double mean_rel = 0, u = 0;  // the β-weighted mean relative difference and its u
  Decision decision = Decision::agrees;
};

// The scan's decision: the rule's three (Decision, with the same values) and the instrument
// outside its datasheet.
enum class VerdictDecision {
  agrees = static_cast<int>(Decision::agrees),
  undecided = static_cast<int>(Decision::undecided),
  out_of_tolerance = static_cast<int>(Decision::out_of_tolerance),
  instrument_out_of_spec,
};
inline constexpr EnumNames<VerdictDecision, 4> kVerdictDecisionNames{{
    {VerdictDecision::agrees, "agrees"},
    {VerdictDecision::undecided, "undecided"},
    {VerdictDecision::out_of_tolerance, "out_of_tolerance"},
    {VerdictDecision::instrument_out_of_spec, "instrument_out_of_spec"},
}};
constexpr const auto& enum_names(VerdictDecision) { return kVerdictDecisionNames; }  // proto/enum_text.hpp
constexpr VerdictDecision verdict_decision(Decision d) { return static_cast<VerdictDecision>(d); }
// Whether a decision raises the scan's sustained-divergence alert.
constexpr bool alerts(VerdictDecision d) {
  return d == VerdictDecision::out_of_tolerance || d == VerdictDecision::instrument_out_of_spec;
}

struct ScanVerdict {
  VerdictDecision decision = VerdictDecision::undecided;
  std::string summary;
  std::optional<VerdictCause> cause;
  std::optional<VerdictCause> calibration_hint;  // an in-spec instrument input worth calibrating
  // Whether the fit that decided (the named cause's, else H0's) leaves a χ² consistent with
  // its degrees of freedom; p_value is P(χ² ≥ observed).
  bool explained = true;
  double p_value = 1;
  double chi2_per_dof = 0;
  std::size_t points_used = 0;
  double delta_chi2_next = 0;          // how much better the named cause fits than the next
  std::vector<VerdictCause> alike;     // candidates as good (a tie)
  struct Candidate {
    VerdictCause cause;
    double delta_chi2 = 0;  // χ² of H0 minus the candidate's
  };
  std::vector<Candidate> candidates;   // every candidate within its linear range, best first
  std::vector<MisfitRegion> regions;   // the worst regions when nothing explains the residuals

  bool alerts() const { return daemon::alerts(decision); }
  nlohmann::json to_json() const;
};

class ScanEvidence {
 public:
  // Δχ² for a candidate to count, and for it to be told from the next (one parameter:
  // 25 ≈ 5σ; 9 ≈ 3σ).
  static constexpr double kSignificant = 25.0;
  static constexpr double kTie = 9.0;
  // A fit explains the residuals when P(χ² ≥ observed | its dof) is at least this (≈ 3.1σ).
  static constexpr double kConsistent = 1e-3;
  // The twin's model of a candidate is its Taylor series at the catalogue (slope, and
  // curvature for the arms): a change as large as the fitted one leaves that series' remainder
  // in the residuals. The consistency test allows up to this fraction of the candidate's own
  // effect, point by point, as that remainder; a scale (a band, the white's gain) is exact.
  static constexpr double kTruncation = 0.1;
  // Random scatter is named when its extra variance stands 5σ above zero and the residuals
  // along the arms' sensitivity are not correlated from point to point (lag-1 ρ below this):
  // a systematic misfit is smooth over neighbouring points, scatter is not.
  static constexpr double kScatterZ = 5.0;
  static constexpr double kScatterRho = 0.5;
  static constexpr double kMinScatterVar = 0.0025;  // deg²: σ0 when no repeatability is stated
  static constexpr double kRegionDeg = 10.0;

  ScanEvidence(double tolerance, double coverage_k) : tolerance_(tolerance), k_(coverage_k) {}

  // Adds a point with its prediction, budget and sample sensitivities (others are skipped).
  void add(const PointRecord& p);
  std::size_t points() const noexcept { return points_; }
  std::size_t candidates() const noexcept;  // candidate causes (arms, white, sample parameters)

  ScanVerdict verdict() const;

 private:
  struct Column {
    std::string name, kind, unit;
    double prior_u = 0;   // 0: no prior (a sample parameter)
    double limit = 0;     // datasheet limit (instrument)
    double nominal = 0;
    // How far the linear model is trusted: a fitted change beyond it is an extrapolation
    // of a finite difference, not evidence (see verdict()).
    double max_change = 0;
    bool curved = false;  // the budget states ∂²β/∂x² (arm offsets): β = c1·θ + ½·c2·θ²
    bool bounded = false; // rectangular or triangular: held within ±limit when not free
    // A band: the nodes (sample columns) scaled together; its θ is the relative change.
    std::vector<std::size_t> members;
    double band_lo = 0, band_hi = 0;
    // The catalogue's β scaled over channels [first, last) (a catalogue with no parameter: a
    // master, a table); its θ is the relative change.
    std::size_t first_channel = 0, last_channel = 0;
    bool band() const { return !members.empty() || last_channel > first_channel; }
  };
  struct Fit {
    std::vector<std::size_t> free;  // columns without prior
    double chi2 = 0;
    std::vector<double> theta, u;   // over all columns in the fit
    std::vector<std::size_t> index;
  };
  // A candidate cause: one column set free, the rest held to their priors.
  struct Fitted {
    std::size_t column;
    Fit fit;
  };
  // Per wavelength band of the verdict (up to three) and per region, the moments a mean
  // relative difference needs, so that a verdict costs the same at the thousandth point as at
  // the tenth: Σ p²/v, Σ p·r/v, and per column Σ p·s/v of its sensitivity, its curvature and
  // its interaction term.
  struct Moments {
    double pp = 0, pr = 0;
    std::vector<double> ps, pc2, px;
  };
  struct Region {
    double theta_i = 0;
    int bin = 0;
    std::size_t points = 0, channels = 0;
    Moments moments;
    std::vector<double> G;  // this region's share of G_ (E × E)
  };
  struct MeanResult {
    Decision decision = Decision::agrees;
    double worst_rel = 0, worst_u = 0;  // the worst group's mean relative difference and u
  };
  // Random scatter along the arms' sensitivity beyond the stated repeatability.
  struct Scatter {
    double extra_var = 0, u_extra_var = 0;  // σ² beyond the stated, deg²
    double rho = 0;                         // lag-1 correlation of the projected residuals
    bool named = false;
  };

  Fit solve(const std::vector<std::size_t>& columns, const std::vector<std::size_t>& free) const;
  bool is_candidate(std::size_t column) const;
  // The steps of verdict(): each candidate fitted (within its linear range, best first), the
  // cause it names, what is left per band once its instrument inputs are removed, a sample
  // parameter's effect point by point, and the decision a candidate leads to.
  std::vector<Fitted> fit_candidates(const std::vector<std::size_t>& instrument,
                                     const std::vector<std::size_t>& sample) const;
  double dof(std::size_t free) const { return static_cast<double>(std::max<std::size_t>(1, n_ - free)); }
  std::vector<double> coefficients(const std::vector<std::size_t>& columns, const std::vector<double>& theta) const;
  VerdictCause cause_of(const Fitted& c) const;
  MeanResult mean_decision(const Fit& fit, const Moments& m, double scale, MeanResult out) const;
  MeanResult band_decision(const Fit& fit) const;
  std::vector<MisfitRegion> regions_of(const Fit& fit) const;
  Scatter scatter_of(const Fit& fit) const;
  double truncation_chi2(const Fitted& c) const;
  Decision effect_decision(const Fitted& c, std::size_t& out_points) const;
  VerdictDecision decide_for(const Fitted& c, std::string& text) const;
  std::string tolerance_text() const;
  void setup(const PointRecord& p);
  void add_bands(const WavelengthGrid& wavelengths);
  void add_scatter_terms(std::vector<double> a, double q);
  Region& region_of(const Geometry& g);
  void unexplained(ScanVerdict& v, const Fit& fit, const std::string& why) const;
  void name_scatter(ScanVerdict& v, const Fit& h0, const Scatter& s) const;

  double tolerance_, k_;
  std::vector<Column> names_;
  std::size_t points_ = 0;
  std::size_t points_out_ = 0;  // points out of tolerance judged alone (decide, per channel)
  // Per point, per sample column: the smallest tolerance·|β| / |∂β/∂x| over the channels
  // (+∞ where no channel is sensitive), all that the rule needs to judge a fitted change of
  // x at that point (effect_decision). Point after point, sample column after column.
  std::vector<double> margins_;
  std::vector<std::size_t> sample_columns_;
  std::size_t channels_ = 0;
  // The weighted Gram matrix G = Σ w e eᵀ of the extended columns e = (each column's
  // sensitivity, the curvature of each curved one, the residual r), n residuals. Every fit's
  // normal equations and χ² are quadratic forms in G, so a verdict costs a few small solves
  // however many points are in.
  std::vector<double> G_;  // E × E, column-major (Eigen's order: verdict.cpp maps it)
  std::size_t E_ = 0;
  std::vector<std::size_t> curvature_of_;  // extended index of column j's curvature, or npos
  std::vector<std::size_t> cross_of_;      // extended index of column j's interaction, or npos
  std::vector<std::size_t> partner_;       // the column j interacts with (β += c·θ_j·θ_partner)
  std::size_t residual_ = 0;               // extended index of r
  std::vector<Moments> bands_;
  std::vector<std::size_t> band_of_;       // each channel's band
  std::vector<Region> regions_;
  // Scatter: per point the residual projected on the arms' sensitivity g (weights 1/var),
  // z = aᵀβ' with a = Σ g e / (var √q) and q = Σ g²/var; var z = 1 + σ²q under extra
  // scatter σ². With each point's weight w (add_scatter_terms), Σ w a aᵀ, Σ a aᵀ,
  // Σ a_i a_{i−1}ᵀ and Σ w, Σ w q, Σ w², Σ w² q, Σ w² q² are what the estimate needs.
  std::vector<double> Zw_, Zs_, Lag_;  // E × E
  std::vector<double> previous_a_;
  double sum_w_ = 0, sum_wq_ = 0, sum_w2_ = 0, sum_w2q_ = 0, sum_w2q2_ = 0;
  double repeatability_u_ = 0;  // the profile's stated repeatability (standard uncertainty)
  std::size_t n_ = 0;
};

}  // namespace gonio::daemon
