// The scan's verdict from all of its points (see verdict.hpp).
#include "gonio/daemon/instrument/verdict.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/daemon/instrument/divergence.hpp"
#include "instrument/evidence_matrix.hpp"

namespace gonio::daemon {
using evidence::chi2_p_value;
namespace {

// What an instrument input is, in the verdict's words.
std::string describe(const VerdictCause& c) {
  if (c.band_nm)
    return fmt::format("{} {:g}–{:g} nm scaled by {:.4f} ± {:.4f} ({:+.1f} %)", c.parameter.substr(0, c.parameter.rfind('@')),
                       (*c.band_nm)[0], (*c.band_nm)[1], c.value, c.u, 100 * (c.value - 1));
  if (c.parameter == "position_repeatability_deg")
    return fmt::format("random arm scatter of {:.3f} ± {:.3f}° per move (stated {:.3f}°)", c.value, c.u, c.nominal);
  if (c.kind == "sample")
    return fmt::format("{} = {:.4g} ± {:.2g} (catalogued {:.4g})", c.parameter, c.value, c.u, c.nominal);
  if (c.parameter == "incidence_arm_deg")
    return fmt::format("an incidence-arm offset of {:+.3f} ± {:.3f}°", c.value, c.u);
  if (c.parameter == "receive_arm_deg")
    return fmt::format("a receive-arm offset of {:+.3f} ± {:.3f}°", c.value, c.u);
  if (c.parameter == "gain") return fmt::format("a reference-white gain of {:.4f} ± {:.4f}", c.value, c.u);
  if (c.parameter == "source_aperture_rel")
    return fmt::format("a source aperture {:.3f} ± {:.3f} × its stated size", c.value, c.u);
  return fmt::format("a receiver aperture {:.3f} ± {:.3f} × its stated size", c.value, c.u);
}

}  // namespace

nlohmann::json ScanVerdict::to_json() const {
  const auto cause_json = [](const std::optional<VerdictCause>& c) -> nlohmann::json {
    if (!c) return nullptr;
    nlohmann::json j{{"kind", c->kind}, {"parameter", c->parameter}, {"value", c->value},
                     {"u", c->u},       {"nominal", c->nominal}};
    if (c->band_nm) {
      j["band_nm"] = {(*c->band_nm)[0], (*c->band_nm)[1]};
      j["scale"] = c->value;
    }
    return j;
  };
  nlohmann::json alike_json = nlohmann::json::array();
  for (const auto& a : alike) alike_json.push_back(cause_json(a));
  nlohmann::json candidates_json = nlohmann::json::array();
  for (const auto& c : candidates) {
    auto j = cause_json(c.cause);
    j["delta_chi2"] = c.delta_chi2;
    candidates_json.push_back(std::move(j));
  }
  nlohmann::json regions_json = nlohmann::json::array();
  for (const auto& r : regions)
    regions_json.push_back({{"theta_i", r.theta_i},
                            {"aspecular", {r.aspecular_lo, r.aspecular_hi}},
                            {"points", r.points},
                            {"chi2_per_n", r.chi2_per_n},
                            {"mean_rel", r.mean_rel},
                            {"u", r.u},
                            {"decision", to_text(r.decision)}});
  return nlohmann::json{{"decision", to_text(decision)},
                        {"summary", summary},
                        {"cause", cause_json(cause)},
                        {"calibration_hint", cause_json(calibration_hint)},
                        {"explained", explained},
                        {"p_value", p_value},
                        {"chi2_per_dof", chi2_per_dof},
                        {"points_used", points_used},
                        {"delta_chi2_next", delta_chi2_next},
                        {"alike", std::move(alike_json)},
                        {"candidates", std::move(candidates_json)},
                        {"regions", std::move(regions_json)}};
}

std::string ScanEvidence::tolerance_text() const {
  return fmt::format("±{:g} % (k = {:g})", 100 * tolerance_, k_);
}

namespace {
std::string in_words(Decision d) {
  return d == Decision::agrees ? "within tolerance" : d == Decision::out_of_tolerance ? "out of tolerance" : "not decided";
}
std::string short_text(Decision d) {
  return d == Decision::agrees ? "agrees" : d == Decision::out_of_tolerance ? "out of tolerance" : "undecided";
}
}  // namespace

// A candidate's own decision (for the named cause and for ties), and the sentence that says why.
VerdictDecision ScanEvidence::decide_for(const Fitted& c, std::string& text) const {
  const auto cause = cause_of(c);
  if (cause.kind == "instrument") {
    const auto& col = names_[c.column];
    const double off = std::abs(cause.value - cause.nominal);
    if (off - k_ * cause.u > col.limit) {
      text = fmt::format("the instrument is outside its datasheet: {} (stated ±{:.3g}{})", describe(cause),
                         col.limit, col.unit == "deg" ? "°" : "");
      return VerdictDecision::instrument_out_of_spec;
    }
    const auto b = band_decision(c.fit);
    text = fmt::format("{} within the datasheet explains the points; with it removed the sample is {} "
                       "(worst band {:+.2f} ± {:.2f} %, tolerance {})",
                       describe(cause), in_words(b.decision), 100 * b.worst_rel, 100 * b.worst_u, tolerance_text());
    return verdict_decision(b.decision);
  }
  std::size_t out_points = 0;
  const auto d = effect_decision(c, out_points);
  text = fmt::format("the sample differs from its catalogue: {}; {}", describe(cause),
                     d == Decision::out_of_tolerance
                         ? fmt::format("beyond the tolerance {} at {} of {} points", tolerance_text(), out_points,
                                       points_)
                     : d == Decision::agrees ? fmt::format("within the tolerance {} at every point", tolerance_text())
                                             : fmt::format("not decidable against the tolerance {}", tolerance_text()));
  return verdict_decision(d);
}

// No candidate explains the residuals: no cause is named. The scan is judged on the bands and
// the regions under `fit` (the catalogue with the instrument within its data sheet), their
// uncertainty scaled by the misfit, and the worst regions are listed.
void ScanEvidence::unexplained(ScanVerdict& v, const Fit& fit, const std::string& why) const {
  v.cause.reset();
  v.explained = false;
  v.chi2_per_dof = fit.chi2 / dof(fit.free.size());
  v.p_value = chi2_p_value(fit.chi2, dof(fit.free.size()));
  auto regions = regions_of(fit);
  const auto bands = band_decision(fit);
  Decision d = bands.decision;
  for (const auto& r : regions) d = worse(d, r.decision);
  // A departure confined to a few points is diluted in any mean: the points judged alone
  // (with the instrument's systematic inputs in their u) count too.
  if (points_out_ > 0) d = Decision::out_of_tolerance;
  if (regions.size() > 3) regions.resize(3);
  std::string where;
  for (const auto& r : regions)
    where += fmt::format("{}θi {:g}°, aspecular {:g}…{:g}°: {:+.2f} ± {:.2f} % (χ²/n {:.3g})", where.empty() ? "" : "; ",
                         r.theta_i, r.aspecular_lo, r.aspecular_hi, 100 * r.mean_rel, 100 * r.u, r.chi2_per_n);
  v.regions = std::move(regions);
  v.decision = verdict_decision(d);
  v.summary = fmt::format("{}: the sample does not match its catalogue; no single parameter explains it ({}; χ²/dof "
                          "{:.3g}, p = {:.2g}); worst regions: {}; {} of {} points out of tolerance on their own "
                          "(tolerance {})",
                          short_text(d), why, v.chi2_per_dof, v.p_value, where, points_out_, points_,
                          tolerance_text());
}

// Random scatter beyond the stated repeatability: an instrument cause and a calibration hint,
// not an alarm about the sample, which is judged per band with the scatter in its uncertainty.
void ScanEvidence::name_scatter(ScanVerdict& v, const Fit& h0, const Scatter& s) const {
  const double total = std::sqrt(repeatability_u_ * repeatability_u_ + s.extra_var);
  // u(σ) from u(σ²): dσ = dσ² / (2σ).
  VerdictCause cause{"instrument", "position_repeatability_deg", total, s.u_extra_var / (2 * total),
                     repeatability_u_, {}};
  const auto b = band_decision(h0);
  v.cause = cause;
  v.calibration_hint = cause;
  v.explained = true;
  v.chi2_per_dof = h0.chi2 / dof(0);
  v.p_value = chi2_p_value(h0.chi2, dof(0));
  v.decision = verdict_decision(b.decision);
  v.summary = fmt::format("{}: the residuals are random from point to point (lag-1 ρ {:.2f}): {} — a calibration "
                          "hint, not the sample; with it in the uncertainty the sample is {} (worst band {:+.2f} ± "
                          "{:.2f} %, tolerance {})",
                          short_text(b.decision), s.rho, describe(cause), in_words(b.decision), 100 * b.worst_rel,
                          100 * b.worst_u, tolerance_text());
}

// H0 (the instrument's inputs held to their data sheets) against one candidate cause at a
// time; the best, if it stands out by kSignificant, no other is within kTie of it and the χ²
// it leaves is consistent with its degrees of freedom, is named, and its decision is the
// scan's. Otherwise random scatter, or no cause (see verdict.hpp).
ScanVerdict ScanEvidence::verdict() const {
  ScanVerdict v;
  v.points_used = points_;
  const auto needed = std::max<std::size_t>(5, 2 * candidates());
  if (points_ < 3 || n_ == 0) {
    v.summary = fmt::format("{} points with predictions: a verdict needs 3, a named cause {}", points_,
                            needed);
    return v;
  }
  std::vector<std::size_t> instrument, sample;
  for (std::size_t j = 0; j < names_.size(); ++j) (names_[j].kind == "sample" ? sample : instrument).push_back(j);
  const auto h0 = solve(instrument, {});
  const bool early = points_ < needed;
  // Too few points for a cause: only the per-band test.
  const auto cands = early ? std::vector<Fitted>{} : fit_candidates(instrument, sample);
  for (const auto& c : cands) v.candidates.push_back({cause_of(c), h0.chi2 - c.fit.chi2});
  v.chi2_per_dof = h0.chi2 / dof(0);
  v.p_value = chi2_p_value(h0.chi2, dof(0));
  const bool h0_consistent = v.p_value >= kConsistent;
  const auto scatter = early || h0_consistent ? Scatter{} : scatter_of(h0);
  // Evidence: a candidate that lowers χ² by kSignificant. (H0 holds each rectangular input
  // within its stated limit, so an arm truly beyond it cannot hide in H0's prior.)
  const bool significant = !cands.empty() && std::isfinite(cands.front().fit.chi2) &&
                           h0.chi2 - cands.front().fit.chi2 > kSignificant;
  if (!significant) {
    if (scatter.named) {
      name_scatter(v, h0, scatter);
    } else if (early || h0_consistent) {
      const auto b = band_decision(h0);
      v.decision = verdict_decision(b.decision);
      v.explained = h0_consistent;
      v.summary = fmt::format("{} over {} points: the worst band differs by {:+.2f} ± {:.2f} % (tolerance {}); {} (χ²/dof {:.3g})",
                              short_text(b.decision), points_, 100 * b.worst_rel, 100 * b.worst_u, tolerance_text(),
                              early ? fmt::format("the cause is undetermined until {} points are in", needed)
                                    : std::string("no candidate cause stands out"),
                              v.chi2_per_dof);
    } else {
      unexplained(v, h0, "no candidate cause stands out");
    }
    return v;
  }
  const auto& best = cands.front();
  v.delta_chi2_next = cands.size() > 1 ? cands[1].fit.chi2 - best.fit.chi2 : 0;
  const double best_p = chi2_p_value(std::max(0.0, best.fit.chi2 - truncation_chi2(best)), dof(1));
  if (best_p < kConsistent) {
    // The best candidate improves on H0 but does not explain what is left: naming it would
    // blame one parameter for a misfit it does not account for.
    if (scatter.named)
      name_scatter(v, h0, scatter);
    else
      unexplained(v, h0, fmt::format("the best candidate, {}, leaves χ²/dof {:.3g}", describe(cause_of(best)),
                                     best.fit.chi2 / dof(1)));
    return v;
  }
  v.chi2_per_dof = best.fit.chi2 / dof(1);
  v.p_value = best_p;
  std::string text;
  v.decision = decide_for(best, text);
  std::vector<const Fitted*> tied;
  for (std::size_t i = 1; i < cands.size(); ++i)
    if (cands[i].fit.chi2 - best.fit.chi2 < kTie) tied.push_back(&cands[i]);
  if (!tied.empty()) {
    // The points cannot tell these apart: no cause is named. When every one of them alerts,
    // the measurement is out of tolerance whichever it is.
    std::string names = describe(cause_of(best));
    bool same = true, all_alert = v.alerts();
    for (const auto* t : tied) {
      std::string other;
      const auto d = decide_for(*t, other);
      same = same && d == v.decision;
      all_alert = all_alert && alerts(d);
      v.alike.push_back(cause_of(*t));
      names += " or " + describe(v.alike.back());
    }
    v.alike.insert(v.alike.begin(), cause_of(best));
    if (!same) v.decision = all_alert ? VerdictDecision::out_of_tolerance : VerdictDecision::undecided;
    v.summary = fmt::format("{}: the twin disagrees (χ²/dof {:.3g} → {:.3g}) but the points cannot tell {} "
                            "apart (undetermined cause)",
                            to_text(v.decision), h0.chi2 / dof(0), v.chi2_per_dof, names);
    return v;
  }
  v.cause = cause_of(best);
  if (v.cause->kind == "instrument" && v.decision != VerdictDecision::instrument_out_of_spec &&
      std::abs(v.cause->value - v.cause->nominal) - k_ * v.cause->u > 0) {
    v.calibration_hint = v.cause;
    v.cause.reset();  // an in-spec input is not what is wrong with the scan
  }
  v.summary = fmt::format("{}: {} (χ²/dof {:.3g} → {:.3g}, Δχ² {:.3g} over the next candidate)", to_text(v.decision), text,
                          h0.chi2 / dof(0), v.chi2_per_dof, v.delta_chi2_next);
  return v;
}

}  // namespace gonio::daemon
