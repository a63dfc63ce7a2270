// The run of one scan and the steps of its points (scan_run.hpp).
#include "instrument/scan_run.hpp"

#include <algorithm>
#include <cmath>
#include <thread>
#include <utility>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/instrument/catalogue.hpp"
#include "gonio/daemon/instrument/plan_check.hpp"
#include "gonio/daemon/instrument/point_reduction.hpp"

namespace gonio::daemon {

using drivers::Axis;
using nlohmann::json;

namespace {

std::string plan_model(const ScanPlan& plan) {
  return plan.adaptive && plan.adaptive->mode == AdaptiveMode::parameters ? plan.adaptive->model : "";
}

// The reason a completed adaptive scan carries: why it stopped, and a misfit said plainly.
std::string adaptive_summary(const twin::DesignStatus& st, const ScanPlan& plan) {
  std::string s = st.state == twin::DesignState::target_reached
                      ? fmt::format("adaptive: target reached in {} points", st.points_used)
                  : st.state == twin::DesignState::max_points
                      ? fmt::format("adaptive: stopped at max_points ({}) before the target", plan.adaptive->max_points)
                      : fmt::format("adaptive: no candidate left to measure after {} points", st.points_used);
  if (st.misfit)
    s += fmt::format("; the model does not describe the data (χ²/dof = {:.3g})", st.chi2_per_dof.value_or(0));
  return s;
}

// Points of a scan judged one by one before the verdict is judged less often (see step 8).
constexpr std::size_t kJudgeEvery = 256;

double seconds_since(ScanRun::Clock::time_point t0) {
  return std::chrono::duration<double>(ScanRun::Clock::now() - t0).count();
}

// Runs `f`, adding its seconds to `device_s`; a failure is `party`'s.
template <class F>
void device_call(FaultParty party, double& device_s, F&& f) {
  const auto t0 = ScanRun::Clock::now();
  try {
    f();
  } catch (const Error& e) {
    device_s += seconds_since(t0);
    throw PointFault(party, e);
  }
  device_s += seconds_since(t0);
}

}  // namespace

ScanRun::ScanRun(const RunContext& ctx, const Scan& scan, std::optional<Geometry> arms)
    : ctx_(ctx), scan_(scan) {
  Store& store = ctx_.store;
  next_ = static_cast<std::size_t>(store.next_point_index(scan.id));
  const auto sample = store.sample(scan.plan.sample_id);
  tolerance_ = sample ? sample->spec.tolerance : 0;
  evidence_ = ScanEvidence(tolerance_, ctx_.divergence.coverage_k);
  // A resumed scan's verdict weighs the points stored before, as if it had never stopped;
  // an adaptive scan's loop resumes from them.
  std::vector<PointRecord> stored;
  for (std::size_t first = 0; first < next_; first += 1000)
    for (auto& p : store.points(scan.id, first, 1000)) {
      evidence_.add(p);
      if (scan.plan.adaptive) stored.push_back(std::move(p));
    }
  if (const auto last = store.latest_fit(scan.id, FitKind::verdict)) {
    const auto& v = last->result;
    verdict_stored_ = v.value("decision", "") + "|" + (v.contains("cause") && v["cause"].is_object() ? v["cause"].value("parameter", "") : "");
    sustained_raised_ = v.value("decision", "") == "out_of_tolerance" || v.value("decision", "") == "instrument_out_of_spec";
  }
  sample_id_ = scan.plan.sample_id;
  // One profile for the whole run, even if a calibration replaces it meanwhile.
  auto snap = ctx_.twin.snapshot();
  twin_version_ = snap.twin_version;
  reference_beta_ = snap.profile.reference_beta;
  if (!sample || !sample->spec.bsdf) {
    prediction_note_ = "the sample has no reference BSDF: measured without predictions";
  } else {
    try {
      spec_ = *sample->spec.bsdf;
      const auto& grid = scan.plan.wavelengths;
      ScanTwin::CatalogueU catalogue_u;
      if (auto cat = std::make_shared<const Catalogue>(Catalogue::of(*sample)); cat->has_u())
        catalogue_u = [cat, grid](const Geometry& g) { return cat->relative_u(g, grid); };
      TwinService& twin = ctx_.twin;
      auto tw = std::make_shared<const ScanTwin>(
          twin.make(spec_, grid, "sample.bsdf", snap.profile), spec_,
          [&](const std::string& spec) { return twin.make(spec, grid, "sample.bsdf", snap.profile); },
          std::move(catalogue_u));
      if (scan.plan.adaptive) scan_twin_ = std::move(tw);  // a batch per chosen point
      else if (next_ < scan.points_total)
        batch_ = twin.batch(std::move(tw), scan.plan.geometries, scan.plan.geometry_index(next_));
    } catch (const Error& e) {
      prediction_note_ = fmt::format("no predictions: {}", e.what());
      spdlog::warn("scan {}: {}", scan.id, prediction_note_);
    }
  }
  if (scan.plan.adaptive) {
    try {
      const auto& guard = ctx_.guard;
      adaptive_ = std::make_unique<AdaptiveLoop>(
          scan.plan, snap.profile,
          [&guard](const Geometry& a, const Geometry& b) { return arms_can_move(guard, a, b); });
      adaptive_->restore(stored);
      candidate_ = adaptive_->first(arms);
      adaptive_status_ = adaptive_->status().to_json();
    } catch (const Error& e) {
      failure_ = fmt::format("the adaptive loop cannot run: {}", e.what());
    }
  }
  colorimeter_ = colorimeter_for(scan.plan.wavelengths);
  drift_ = ReferenceDriftMonitor(ctx_.divergence.reference_drift);
  scan_.state = ScanState::running;
}

ScanRun::~ScanRun() {
  if (batch_) batch_->cancel();
}

json ScanRun::adaptive_status() const {
  std::lock_guard lock(status_mu_);
  return adaptive_status_;
}

void ScanRun::set_adaptive_status(json j) {
  std::lock_guard lock(status_mu_);
  adaptive_status_ = std::move(j);
}

ScanRun::Point ScanRun::begin_point() {
  const std::size_t idx = next_;
  Point pt;
  pt.geometry = adaptive_ ? *candidate_ : scan_.plan.geometry_index(idx);
  const Geometry& g = scan_.plan.geometries[pt.geometry];
  if (adaptive_ && !choosing_) {
    // The loop chooses the point after this one while the arms serve this one, and the
    // twin predicts this one meanwhile.
    adaptive_->measuring(pt.geometry);
    choosing_ = true;
    if (scan_twin_) batch_ = ctx_.twin.batch(scan_twin_, {g}, 0);
  }
  pt.started = Clock::now();
  PointRecord& p = pt.record;
  p.scan_id = scan_.id;
  p.index = static_cast<std::int64_t>(idx);
  p.geometry_index = static_cast<std::int64_t>(pt.geometry);
  p.repeat = adaptive_ ? adaptive_->readings(pt.geometry) - 1
                       : static_cast<int>(idx % static_cast<std::size_t>(scan_.plan.repeats));
  p.planned = g;
  p.started_at = utc::now();
  return pt;
}

// Step 3: the arms to the geometry, the dark, the reference white when due and the sample
// (auto-ranged: auto_ranger.hpp), the arms read back.
PointReadings ScanRun::read(Point& pt, PointDevices& d) {
  const Geometry& g = pt.record.planned;
  PointRecord& p = pt.record;
  const auto& c = ctx_.config;
  // The travel as ScanTiming prices it: the arms and the sample's rotation, one after another.
  const auto travel = [&](Axis a, double to) {
    const auto at = d.at.find(a);
    return at == d.at.end() ? 0.0 : std::abs(to - at->second);
  };
  pt.timing.travel_deg = travel(Axis::incidence, g.theta_i) + travel(Axis::receive, g.theta_r) +
                         (d.has_rotation ? travel(Axis::rotation, g.phi_i) : 0.0);
  const double before_move = pt.device_s;
  device_call(FaultParty::motion, pt.device_s, [&] {
    d.arms.move(d.motion, d.at, g.theta_i, g.theta_r, d.has_rotation ? std::optional<double>(g.phi_i) : std::nullopt);
    if (c.settle.count() > 0) {
      ctx_.beat();
      std::this_thread::sleep_for(c.settle);
    }
  });
  pt.timing.move_s = pt.device_s - before_move;
  PointReadings in;
  device_call(FaultParty::photometer, pt.device_s, [&] {
    if (!nominal_ms_) nominal_ms_ = d.ranger.nominal_ms(d.photometer);
    const bool due = !reference_.white || scan_.plan.reads_reference(since_start_);
    in = d.ranger.read(d.photometer, *nominal_ms_, due, reference_, fmt::format("scan {} point {}", scan_.id, p.index));
  });
  pt.timing.reading_s = pt.device_s - pt.timing.move_s - before_move;
  if (in.integration_ms > 0) p.integration_ms = in.integration_ms;
  device_call(FaultParty::motion, pt.device_s, [&] {
    ctx_.beat();
    p.actual.theta_i = d.motion.position(Axis::incidence, c.move_timeout);
    ctx_.beat();
    p.actual.theta_r = d.motion.position(Axis::receive, c.move_timeout);
    if (d.has_rotation) {
      ctx_.beat();
      p.actual.phi_i = p.actual.phi_r = d.motion.position(Axis::rotation, c.move_timeout);
    }
  });
  return in;
}

// Step 4: β and its uncertainty on the plan's grid (point_reduction.hpp), and the reference
// white's drift against the run's first reading. Readings the reduction cannot use (a
// reference not above dark, channel counts that differ) are the photometer's fault.
void ScanRun::reduce(const PointReadings& in, PointRecord& p) {
  std::optional<ReducedPoint> reduced;
  try {
    reduced = reduce_point(PointSignals{.sample = in.sample.spectrum,
                                        .dark = in.dark.spectrum,
                                        .reference = reference_.white->spectrum,
                                        .reference_dark = reference_.dark->spectrum},
                           reference_beta_, scan_.plan.wavelengths);
  } catch (const Error& e) {
    if (e.code() != Errc::protocol_error && e.code() != Errc::device_alarm) throw;
    throw PointFault(FaultParty::photometer, e);
  }
  p.measured = std::move(reduced->beta);
  if (in.read_reference) p.flags.push_back("reference_read");
  if (in.sample.saturated) p.flags.push_back("saturated");
  if (!in.read_reference) return;

  // Counts grow with the integration time: the drift compares counts per nominal setting.
  auto net = reduced->net_reference;
  if (nominal_ms_.value_or(0) > 0 && reference_.white->integration_ms > 0)
    for (auto& v : net) v *= *nominal_ms_ / reference_.white->integration_ms;
  if (const auto drift = drift_.observe(net)) {
    p.flags.push_back("reference_drift");
    ctx_.alerts.raise(AlertDraft{.kind = std::string(alert_kind::reference_drift),
                                 .severity = Severity::warning,
                                 .dedup_key = fmt::format("reference_drift:scan:{}", scan_.id),
                                 .scan_id = scan_.id,
                                 .sample_id = sample_id_,
                                 .point_index = p.index,
                                 .message = fmt::format("scan {}: the reference white reading drifted {:.1f} % "
                                                        "from its first reading (limit {:.1f} %)",
                                                        scan_.id, 100 * *drift, 100 * drift_.limit())});
  }
}

// Step 5: the twin's prediction, computed ahead, with its uncertainty budget and the
// sample's sensitivities; the point judged by the decision rule (divergence.hpp). Never a
// fault: a prediction that failed is a flag on the point.
void ScanRun::predict_and_judge(Point& pt) {
  PointRecord& p = pt.record;
  if (!batch_) {
    p.flags.push_back("no_prediction");
    return;
  }
  ctx_.beat();
  const auto t0 = Clock::now();
  try {
    auto pp = batch_->wait(adaptive_ ? 0 : pt.geometry);
    p.predicted = pp.prediction.spectrum();
    p.twin_version = twin_version_;
    p.u_model = pp.budget.u_model;
    p.budget = budget_entries(pp.budget);
    p.sample_sensitivity = std::move(pp.sample);
    if (!pp.prediction.diagnostics.converged) p.flags.push_back("prediction_unconverged");
  } catch (const Error& e) {
    p.flags.push_back("prediction_failed");
    spdlog::warn("scan {} point {}: no prediction: {}", scan_.id, p.index, e.what());
  }
  pt.twin_s = seconds_since(t0);
  if (p.predicted) {
    const auto d = evaluate_point(p.measured, *p.predicted, p.u_model, p.budget, tolerance_,
                                  colorimeter_.get(), ctx_.divergence);
    p.z_max = d.z_max;
    p.delta_e00 = d.delta_e00;
    p.color = d.color;
    p.decision = to_text(d.decision);
    p.diverged = d.diverged;
    if (d.inconsistent) p.flags.push_back("inconsistent");
  }
}

// Step 6: the point committed in one transaction before the next move. A point already
// stored (its index taken) is skipped, never stored twice; any other failure of the store
// is the store's fault, and the point is measured again after the resume.
void ScanRun::commit(const PointRecord& p, const std::string& text) {
  try {
    ctx_.store.insert_point(p, text);
  } catch (const Error& e) {
    if (e.code() != Errc::invalid_state || e.field() != "index") throw PointFault(FaultParty::store, e);
    spdlog::warn("scan {}: {}; skipping it", scan_.id, e.what());
  }
  ++next_;
  ++since_start_;
}

// Step 7: the point published, as it was stored.
void ScanRun::publish(const std::string& text) {
  ctx_.hub.publish_raw(Topic::points, "scan.point", text, scan_.id);
}

// Step 8: the point's divergence alert, the scan's verdict judged again (the last point's
// always), the adaptive loop told and asked for the next candidate, the progress published.
std::optional<std::string> ScanRun::after_commit(const Point& pt) {
  const PointRecord& p = pt.record;
  busy_seconds_ += seconds_since(pt.started);
  if (p.diverged) {
    ctx_.alerts.raise(AlertDraft{
        .kind = std::string(alert_kind::divergence),
        .severity = Severity::warning,
        .dedup_key = fmt::format("divergence:scan:{}", scan_.id),
        .scan_id = scan_.id,
        .sample_id = sample_id_,
        .point_index = p.index,
        .message = fmt::format("scan {} point {} ({}): out of tolerance (±{:g} %, k = {:g}; max |z| = {:.1f}{})",
                               scan_.id, p.index, p.planned.to_string(), 100 * tolerance_,
                               ctx_.divergence.coverage_k, p.z_max.value_or(0),
                               p.delta_e00 ? fmt::format(", ΔE00 = {:.2f}", *p.delta_e00) : std::string())});
    ++scan_.points_diverged;
  }
  if (p.predicted) {
    evidence_.add(p);
    // Judged after every point up to kJudgeEvery points, then after every n/kJudgeEvery-th:
    // a verdict's cost grows with the points (its per-point effects), so a long scan would
    // otherwise slow as it goes; the last point is always judged (below).
    const auto n = evidence_.points();
    if (n <= kJudgeEvery || ++since_judged_ * kJudgeEvery >= n) {
      since_judged_ = 0;
      judge(p.index, false);
    }
  }
  if (adaptive_) {
    adaptive_->committed(pt.geometry, p, pt.timing);
    choosing_ = false;
    if (next_ < scan_.points_total) candidate_ = adaptive_->next_after(pt.geometry);
    set_adaptive_status(adaptive_->status().to_json());
  }
  publish_progress();
  if (done()) judge(p.index, true);
  return std::exchange(pause_, std::nullopt);
}

std::string ScanRun::complete() {
  if (!adaptive_) return {};
  const auto st = adaptive_->finish(at_max_points());
  auto j = st.to_json();
  set_adaptive_status(j);
  try {
    ctx_.store.insert_fit(scan_.id, FitKind::adaptive, plan_model(scan_.plan), j, "goniod");
  } catch (const Error& e) {
    spdlog::warn("scan {}: cannot store the adaptive loop's state: {}", scan_.id, e.what());
  }
  return adaptive_summary(st, scan_.plan);
}

void ScanRun::end(ScanState state, const std::string& actor) {
  if (batch_) batch_->cancel();
  if (adaptive_ && state != ScanState::completed) {
    // Paused, interrupted, failed or cancelled: scan.get shows the loop as it stopped.
    try {
      ctx_.store.insert_fit(scan_.id, FitKind::adaptive, plan_model(scan_.plan), adaptive_->status().to_json(), actor);
    } catch (const Error& e) {
      spdlog::warn("scan {}: cannot store the adaptive loop's state: {}", scan_.id, e.what());
    }
  }
  set_adaptive_status(json(nullptr));
  // A scan that ends early is judged on every point it has: that verdict resolves or keeps
  // its sustained alert (Instrument::transition()).
  if ((state == ScanState::cancelled || state == ScanState::failed) && evidence_.points() > 0) {
    try {
      ctx_.store.insert_fit(scan_.id, FitKind::verdict, spec_, evidence_.verdict().to_json(), "goniod");
    } catch (const std::exception& e) {
      spdlog::warn("scan {}: cannot store the verdict: {}", scan_.id, e.what());
    }
  }
}

void ScanRun::judge(std::int64_t point_index, bool final) {
  if (evidence_.points() == 0) return;
  const auto v = evidence_.verdict();
  const auto key = std::string(to_text(v.decision)) + "|" + (v.cause ? v.cause->parameter : std::string());
  // Stored when it changes and at the end: scan.get shows the latest.
  if (key != verdict_stored_ || final) {
    try {
      ctx_.store.insert_fit(scan_.id, FitKind::verdict, spec_, v.to_json(), "goniod");
      verdict_stored_ = key;
    } catch (const Error& e) {
      spdlog::warn("scan {}: cannot store the verdict: {}", scan_.id, e.what());
    }
  }
  if (v.alerts()) {
    // One alert per scan, updated (not duplicated) as the verdict firms up.
    const auto alert = ctx_.alerts.raise(AlertDraft{.kind = std::string(alert_kind::sustained),
                                                    .severity = Severity::critical,
                                                    .dedup_key = fmt::format("sustained:scan:{}", scan_.id),
                                                    .scan_id = scan_.id,
                                                    .sample_id = sample_id_,
                                                    .point_index = point_index,
                                                    .message = fmt::format("scan {}: {}", scan_.id, v.summary)});
    // The inverse twin refits the named cause once the whole scan is in.
    if (final && v.cause && ctx_.sustained) ctx_.sustained(scan_.id, alert.id);
    if (!sustained_raised_) {
      sustained_raised_ = true;
      if (ctx_.config.pause_on_sustained) pause_ = "sustained divergence from the twin";
    }
  }
  if (final && v.calibration_hint) {
    ctx_.alerts.raise(AlertDraft{.kind = std::string(alert_kind::calibration_hint),
                                 .severity = Severity::warning,
                                 .dedup_key = fmt::format("calibration_hint:scan:{}", scan_.id),
                                 .scan_id = scan_.id,
                                 .sample_id = sample_id_,
                                 .point_index = point_index,
                                 .message = fmt::format("scan {}: {}", scan_.id, v.summary)});
  }
}

void ScanRun::publish_progress() {
  const auto remaining = scan_.points_total - std::min(scan_.points_total, next_);
  const double per_point = since_start_ ? busy_seconds_ / static_cast<double>(since_start_) : 0;
  ctx_.hub.publish(Topic::progress, "scan.progress",
                   json{{"scan", scan_.id},
                        {"state", "running"},
                        {"reason", ""},
                        {"points_done", next_},
                        {"points_total", scan_.points_total},
                        {"points_diverged", scan_.points_diverged},
                        {"eta_s", per_point * static_cast<double>(remaining)},
                        {"adaptive", adaptive_ ? adaptive_status() : json(nullptr)}},
                   scan_.id);
}

}  // namespace gonio::daemon
