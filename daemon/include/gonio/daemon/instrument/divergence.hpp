// Divergence monitor: does a measured point agree with the twin's prediction?
//
// The sample's tolerance is an acceptance limit, not an uncertainty (ISO 14253-1, JCGM
// 106:2012; docs/decision-rule.md). Per channel c, with d = m − p and its combined standard
// uncertainty u_c = √(u_m² + s_p² + u_model²) (the measurement's, the twin's Monte Carlo
// error, and the twin's budget from the instrument's stated tolerances), T = tol·p and the
// coverage factor k:
//
//     agrees            |d| + k·u_c ≤ T       (guarded acceptance)
//     out_of_tolerance  |d| − k·u_c > T       (guarded rejection)
//     undecided         otherwise
//
// A point is out of tolerance when one channel or its colour is, agrees when every channel
// and its colour agree. Colour is judged the same way: CIEDE2000 (D65, 10°) where CIELAB is
// defined (β ≤ 1), else the chromaticity distance Δu′v′ and the relative luminance Y_m/Y_p
// apart, each with its uncertainty propagated from the spectra's (the budget's components
// correlated across channels). z = d/u_c is kept as a figure. Reference drift compares the
// dark-corrected reference white signal with the scan's first reading.
#pragma once

#include <cstddef>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "gonio/proto/enum_text.hpp"
#include "gonio/proto/point.hpp"
#include "gonio/proto/spectrum.hpp"
#include "gonio/twin/color.hpp"

namespace gonio::daemon {

struct DivergenceSettings {
  double coverage_k = 2.0;
  double z_threshold = 5.0;          // |z| beyond it flags the point "inconsistent"
  double delta_e_threshold = 3.0;    // the colour's acceptance limit, ΔE00
  double delta_uv_threshold = 0.004; // ... and above β = 1, Δu′v′
  double reference_drift = 0.05;
};

// Ordered from best to worst (worse() compares them); named as points and verdicts spell them.
enum class Decision { agrees, undecided, out_of_tolerance };
inline constexpr EnumNames<Decision, 3> kDecisionNames{{
    {Decision::agrees, "agrees"},
    {Decision::undecided, "undecided"},
    {Decision::out_of_tolerance, "out_of_tolerance"},
}};
constexpr const auto& enum_names(Decision) { return kDecisionNames; }  // proto/enum_text.hpp
// The worse of two decisions (out_of_tolerance > undecided > agrees).
Decision worse(Decision a, Decision b);
// The rule itself for a difference d with standard uncertainty u against the limit T.
Decision decide(double d, double u, double limit, double k);

struct PointDivergence {
  double z_max = 0;
  std::size_t worst_channel = 0;
  std::optional<double> delta_e00;   // when CIEDE2000 is defined
  std::optional<ColorCheck> color; // nullopt without a colorimeter for the grid
  Decision decision = Decision::undecided;
  bool diverged = false;             // decision == out_of_tolerance
  bool inconsistent = false;         // z_max > z_threshold
};

// The spectra on the same grid; `budget` (may be empty) correlates the model's uncertainty
// across channels; `u_model` per channel (may be empty: none).
PointDivergence evaluate_point(const Spectrum& measured, const Spectrum& predicted,
                               const std::vector<double>& u_model,
                               const std::vector<BudgetEntry>& budget, double tolerance,
                               const twin::Colorimeter* colorimeter, const DivergenceSettings& s);

// D65 / 10° colorimeter on `grid`, or null when the grid cannot carry colour.
std::shared_ptr<const twin::Colorimeter> colorimeter_for(const WavelengthGrid& grid);

// Relative drift |current / baseline − 1| of the channel-mean reference signal; nullopt
// when the baseline is not positive.
std::optional<double> reference_drift(const std::vector<double>& baseline,
                                      const std::vector<double>& current);

}  // namespace gonio::daemon
