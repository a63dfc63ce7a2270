// Instrument, part 2: one run of a scan on the runner thread (see instrument.hpp) — start
// (predictions ahead, resume point), one point per step (arms, readings, reduction to β,
// reference drift, divergence from the twin, commit, alerts, notifications), finish, device
// faults, and moving the arms in an order that keeps them clear of each other.
#include <algorithm>
#include <cmath>
#include <thread>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/instrument/autorange.hpp"
#include "gonio/daemon/instrument/catalogue.hpp"
#include "gonio/daemon/instrument/instrument.hpp"
#include "gonio/daemon/instrument/point_reduction.hpp"
#include "gonio/proto/error.hpp"
#include "instrument/run.hpp"

namespace gonio::daemon {

using drivers::Axis;
using drivers::Channel;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

bool is_device_error(Errc c) {
  switch (c) {
    case Errc::timeout:
    case Errc::disconnected:
    case Errc::device_alarm:
    case Errc::protocol_error:
    case Errc::saturated:
    case Errc::busy:
    case Errc::limit_violation:
    case Errc::unsupported:
    case Errc::io_error: return true;
    default: return false;
  }
}

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

// Points of a scan judged one by one before the verdict is judged less often (see step 7).
constexpr std::size_t kJudgeEvery = 256;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

}  // namespace

void Instrument::start_run(const Scan& scan) {
  auto r = std::make_unique<Run>();
  r->scan = scan;
  r->next = static_cast<std::size_t>(store_.next_point_index(scan.id));
  const auto sample = store_.sample(scan.plan.sample_id);
  r->tolerance = sample ? sample->spec.tolerance : 0;
  r->evidence = ScanEvidence(r->tolerance, divergence_.coverage_k);
  // A resumed scan's verdict weighs the points stored before, as if it had never stopped;
  // an adaptive scan's loop resumes from them.
  std::vector<PointRecord> stored;
  for (std::size_t first = 0; first < r->next; first += 1000)
    for (auto& p : store_.points(scan.id, first, 1000)) {
      r->evidence.add(p);
      if (scan.plan.adaptive) stored.push_back(std::move(p));
    }
  if (const auto last = store_.latest_fit(scan.id, "verdict")) {
    const auto& v = last->result;
    r->verdict_stored = v.value("decision", "") + "|" + (v.contains("cause") && v["cause"].is_object() ? v["cause"].value("parameter", "") : "");
    r->sustained_raised = v.value("decision", "") == "out_of_tolerance" || v.value("decision", "") == "instrument_out_of_spec";
  }
  r->sample_id = scan.plan.sample_id;
  // One profile for the whole run, even if a calibration replaces it meanwhile.
  auto snap = twin_.snapshot();
  r->twin_version = snap.twin_version;
  r->reference_beta = snap.profile.reference_beta;
  if (!sample || !sample->spec.bsdf) {
    r->prediction_note = "the sample has no reference BSDF: measured without predictions";
  } else {
    try {
      r->spec = *sample->spec.bsdf;
      const auto& grid = scan.plan.wavelengths;
      ScanTwin::CatalogueU catalogue_u;
      if (auto cat = std::make_shared<const Catalogue>(Catalogue::of(*sample)); cat->has_u())
        catalogue_u = [cat, grid](const Geometry& g) { return cat->relative_u(g, grid); };
      auto tw = std::make_shared<const ScanTwin>(
          twin_.make(r->spec, grid, "sample.bsdf", snap.profile), r->spec,
          [&](const std::string& spec) { return twin_.make(spec, grid, "sample.bsdf", snap.profile); },
          std::move(catalogue_u));
      if (scan.plan.adaptive) r->scan_twin = std::move(tw);  // a batch per chosen point
      else if (r->next < scan.points_total)
        r->batch = twin_.batch(std::move(tw), scan.plan.geometries, scan.plan.geometry_index(r->next));
    } catch (const Error& e) {
      r->prediction_note = fmt::format("no predictions: {}", e.what());
      spdlog::warn("scan {}: {}", scan.id, r->prediction_note);
    }
  }
  std::string adaptive_failure;
  if (scan.plan.adaptive) {
    try {
      r->adaptive = std::make_unique<AdaptiveLoop>(
          scan.plan, snap.profile,
          [this](const Geometry& a, const Geometry& b) { return arms_can_move(guard_, a, b); });
      r->adaptive->restore(stored);
      r->candidate = r->adaptive->first(device_facts().arms);
    } catch (const Error& e) {
      adaptive_failure = fmt::format("the adaptive loop cannot run: {}", e.what());
    }
  }
  r->colorimeter = colorimeter_for(scan.plan.wavelengths);
  r->drift = ReferenceDriftMonitor(divergence_.reference_drift);
  const auto resumed = r->next > 0;
  const auto next = r->next;
  r->scan.state = ScanState::running;
  const auto note = r->prediction_note;
  {
    std::lock_guard lock(mu_);
    adaptive_status_ = r->adaptive ? r->adaptive->status().to_json() : json(nullptr);
    run_ = std::move(r);
    running_ = scan.id;
    control_ = Control::none;
  }
  // The run is in place before the state is published, so that whoever reacts to it finds
  // the scan running.
  try {
    transition(scan.id, ScanState::running,
               resumed ? fmt::format("resumed at point {}", next) : std::string(), "goniod");
  } catch (...) {
    std::unique_ptr<Run> dropped;
    {
      std::lock_guard lock(mu_);
      dropped = std::move(run_);
      running_.reset();
    }
    if (dropped && dropped->batch) dropped->batch->cancel();
    throw;
  }
  spdlog::info("scan {}: {} ({} points{}){}", scan.id, resumed ? "resumed" : "started",
               scan.points_total, resumed ? fmt::format(", from point {}", next) : "",
               note.empty() ? "" : "; " + note);
  set_state("scanning", fmt::format("scan {}", scan.id));
  if (status_listener_) status_listener_(fmt::format("scan {} running", scan.id));
  // A scan whose every point is stored (crash after the last commit) completes at once; so
  // does an adaptive one whose loop has reached its target or has nothing left to choose.
  if (!adaptive_failure.empty()) finish_run(ScanState::failed, adaptive_failure, "goniod");
  else if (run_->next >= scan.points_total) finish_adaptive_or_complete(true);
  else if (run_->adaptive && !run_->candidate) finish_adaptive_or_complete(false);
}

void Instrument::finish_run(ScanState state, const std::string& reason, const std::string& actor) {
  std::unique_ptr<Run> r;
  {
    std::lock_guard lock(mu_);
    r = std::move(run_);
    running_.reset();
  }
  if (!r) return;
  if (r->batch) r->batch->cancel();
  if (r->adaptive && state != ScanState::completed) {
    // Paused, interrupted, failed or cancelled: scan.get shows the loop as it stopped.
    try {
      store_.insert_fit(r->scan.id, "adaptive", plan_model(r->scan.plan), r->adaptive->status().to_json(), actor);
    } catch (const Error& e) {
      spdlog::warn("scan {}: cannot store the adaptive loop's state: {}", r->scan.id, e.what());
    }
  }
  {
    std::lock_guard lock(mu_);
    adaptive_status_ = json(nullptr);
  }
  // A scan that ends early is judged on every point it has: that verdict resolves or keeps
  // its sustained alert (transition()).
  if ((state == ScanState::cancelled || state == ScanState::failed) && r->evidence.points() > 0) {
    try {
      store_.insert_fit(r->scan.id, "verdict", r->spec, r->evidence.verdict().to_json(), "goniod");
    } catch (const std::exception& e) {
      spdlog::warn("scan {}: cannot store the verdict: {}", r->scan.id, e.what());
    }
  }
  std::optional<Scan> sc;
  try {
    sc = transition(r->scan.id, state, reason, actor);
    spdlog::info("scan {}: {}{}", r->scan.id, to_text(state),
                 sc->reason.empty() ? "" : ": " + sc->reason);
  } catch (const Error& e) {
    spdlog::error("scan {}: cannot record state {}: {}", r->scan.id, to_text(state), e.what());
    if (e.code() == Errc::storage_unavailable) {
      // Published now, stored once the store can write (check_storage).
      unsaved_state_ = UnsavedState{r->scan.id, state, reason, actor};
      hub_.publish(Topic::state, "scan.state",
                   json{{"scan", r->scan.id}, {"state", to_text(state)}, {"reason", reason}, {"stored", false}},
                   r->scan.id);
    }
  }
  if (sc)
    hub_.publish(Topic::progress, "scan.progress",
                 json{{"scan", sc->id},
                      {"state", to_text(sc->state)},
                      {"reason", sc->reason},
                      {"points_done", sc->points_done},
                      {"points_total", sc->points_total},
                      {"points_diverged", sc->points_diverged},
                      {"eta_s", 0.0}},
                 sc->id);
  settle_state();
  if (status_listener_)
    status_listener_(fmt::format("scan {} {}", r->scan.id, to_text(state)));
  cv_.notify_all();  // pause()/cancel() wait for this
}

void Instrument::on_device_fault(const Error& e) {
  std::int64_t id = 0;
  {
    std::lock_guard lock(mu_);
    id = run_ ? run_->scan.id : 0;
    fault_latched_ = true;
    fault_reason_ = fmt::format("{} ({})", e.what(), e.id());
  }
  const auto reason = fmt::format("device fault: {} ({}); a technician must resume", e.what(), e.id());
  spdlog::error("scan {}: {}", id, reason);
  alerts_.raise(AlertDraft{std::string(alert_kind::device_fault), Severity::critical,
                           fmt::format("device_fault:scan:{}", id), id, std::nullopt,
                           std::nullopt, fmt::format("scan {} paused: {}", id, reason)});
  {
    std::lock_guard sched(sched_mu_);
    finish_run(ScanState::paused, reason, "goniod");
  }
  std::lock_guard lock(mu_);
  if (config_.auto_resume && id != 0 && auto_resumes_[id] < config_.max_auto_resumes) {
    ++auto_resumes_[id];
    auto_resume_ = std::make_pair(id, Clock::now() + config_.auto_resume_delay);
  }
}

double Instrument::nominal_integration_ms() {
  if (!config_.autorange || !photometer_->capabilities().settable_integration) return 0;
  if (!nominal_integration_) {
    // The configured setting, else the photometer's own as goniod first finds it (kept, so
    // that a setting left short by ranging is not taken for the nominal one).
    nominal_integration_ = config_.integration_ms ? *config_.integration_ms
                                                  : photometer_->integration_ms(config_.measure_timeout);
  }
  return std::clamp(*nominal_integration_, config_.integration_min_ms, config_.integration_max_ms);
}

void Instrument::set_integration(double ms) {
  if (integration_set_ && std::abs(*integration_set_ - ms) <= 1e-9 * ms) return;
  integration_set_.reset();  // unknown until the device took it
  photometer_->set_integration_ms(ms, config_.measure_timeout);
  integration_set_ = ms;
}

void Instrument::on_storage_fault(const Error& e) {
  std::int64_t id = 0;
  {
    std::lock_guard lock(mu_);
    id = run_ ? run_->scan.id : 0;
  }
  const auto reason = fmt::format("storage: {}; free space, then resume the scan", e.what());
  spdlog::error("scan {}: {}", id, reason);
  // The pause and its alert may use the store's reserve; without one (a read-only file
  // system) the alert is held in memory and published, the state stored later.
  Store::Essential essential;
  alerts_.raise(AlertDraft{std::string(alert_kind::storage), Severity::critical, "storage:unwritable", id,
                           std::nullopt, std::nullopt, fmt::format("scan {} paused: {}", id, reason)});
  std::lock_guard sched(sched_mu_);
  finish_run(ScanState::paused, reason, "goniod");
}

void Instrument::check_storage() {
  const auto now = std::chrono::steady_clock::now();
  if (now - storage_checked_ < std::chrono::seconds(1)) return;
  storage_checked_ = now;
  // The low-space warning first: on a store that cannot write it is held in memory.
  const auto s = store_.storage();
  if (s.low && !low_space_) {
    low_space_ = true;
    const auto msg = fmt::format("low space: {}; no new scan starts until {:.0f} MiB are free (store.min_free_mb)",
                                 describe_space(s.dir, s.space), static_cast<double>(s.min_free_bytes) / (1 << 20));
    spdlog::warn("store: {}", msg);
    alerts_.raise(AlertDraft{std::string(alert_kind::storage), Severity::warning, "storage:low", std::nullopt,
                             std::nullopt, std::nullopt, msg});
  } else if (!s.low && low_space_) {
    low_space_ = false;
    spdlog::info("store: space is back ({})", describe_space(s.dir, s.space));
  }
  if (!store_.writable() && !store_.probe()) return;
  alerts_.flush_held();
  {
    std::lock_guard sched(sched_mu_);
    if (unsaved_state_) {
      try {
        const auto u = *unsaved_state_;
        transition(u.scan, u.state, u.reason, u.actor);
        unsaved_state_.reset();
        spdlog::info("scan {}: state {} stored now that the store can write", u.scan, to_text(u.state));
      } catch (const Error& e) {
        spdlog::warn("scan {}: state still not stored: {}", unsaved_state_->scan, e.what());
      }
    }
    if (recover_reason_) {
      try {
        for (const auto id : store_.recover_running(*recover_reason_))
          spdlog::warn("scan {} was running when goniod last stopped; it resumes first", id);
        recover_reason_.reset();
      } catch (const Error& e) {
        spdlog::warn("store: scans left running not recovered yet: {}", e.what());
      }
    }
  }
}

json Instrument::storage_json() const {
  const auto s = store_.storage();
  json held = json::array();
  for (const auto& a : alerts_.held()) held.push_back(a);
  return json{{"dir", s.dir.string()},
              {"free_mb", s.space.known ? json(static_cast<double>(s.space.free_bytes) / (1 << 20)) : json(nullptr)},
              {"read_only_fs", s.space.read_only},
              {"writable", s.writable},
              {"low", s.low},
              {"fault", s.fault},
              {"min_free_mb", static_cast<double>(s.min_free_bytes) / (1 << 20)},
              {"reserve", s.reserve},
              {"unsaved_alerts", std::move(held)}};
}

void Instrument::move_arms(double incidence, double receive, std::optional<double> rotation) {
  double cur_i = 0, cur_r = 0;
  bool know = false;
  {
    std::lock_guard lock(mu_);
    know = positions_.contains(Axis::incidence) && positions_.contains(Axis::receive);
    if (know) cur_i = positions_[Axis::incidence], cur_r = positions_[Axis::receive];
  }
  const auto go = [&](Axis a, double target) {
    beat();
    motion_->move(a, target, config_.move_timeout);
    std::lock_guard lock(mu_);
    positions_[a] = target;
  };
  if (!know || std::abs(cur_i - incidence) > 1e-9 || std::abs(cur_r - receive) > 1e-9) {
    // Move the arms one at a time, in the order that keeps them apart all the way.
    bool incidence_first = true;
    if (know) {
      try {
        guard_.check_move(Axis::incidence, cur_i, incidence, cur_r);
        guard_.check_move(Axis::receive, cur_r, receive, incidence);
      } catch (const Error&) {
        guard_.check_move(Axis::receive, cur_r, receive, cur_i);
        guard_.check_move(Axis::incidence, cur_i, incidence, receive);
        incidence_first = false;
      }
    }
    if (incidence_first) {
      if (!know || std::abs(cur_i - incidence) > 1e-9) go(Axis::incidence, incidence);
      if (!know || std::abs(cur_r - receive) > 1e-9) go(Axis::receive, receive);
    } else {
      go(Axis::receive, receive);
      go(Axis::incidence, incidence);
    }
  }
  if (rotation) {
    double cur = 0;
    bool have = false;
    {
      std::lock_guard lock(mu_);
      have = positions_.contains(Axis::rotation);
      if (have) cur = positions_[Axis::rotation];
    }
    if (!have || std::abs(cur - *rotation) > 1e-9) go(Axis::rotation, *rotation);
  }
}

// One point, as docs/architecture.md §6 tells it: its steps 3–7, each a function below.
void Instrument::step() {
  Run& r = *run_;
  const std::size_t idx = r.next;
  const std::size_t gi = r.adaptive ? *r.candidate : r.scan.plan.geometry_index(idx);
  const Geometry& g = r.scan.plan.geometries[gi];
  if (r.adaptive && !r.choosing) {
    // The loop chooses the point after this one while the arms serve this one, and the
    // twin predicts this one meanwhile.
    r.adaptive->measuring(gi);
    r.choosing = true;
    if (r.scan_twin) r.batch = twin_.batch(r.scan_twin, {g}, 0);
  }
  const auto t_start = Clock::now();

  PointRecord p;
  p.scan_id = r.scan.id;
  p.index = static_cast<std::int64_t>(idx);
  p.geometry_index = static_cast<std::int64_t>(gi);
  p.repeat = r.adaptive ? r.adaptive->readings(gi) - 1
                        : static_cast<int>(idx % static_cast<std::size_t>(r.scan.plan.repeats));
  p.planned = g;
  p.started_at = utc::now();

  const auto readings = read_point(g, p);
  if (!readings) return;
  if (!reduce(*readings, p)) return;
  const double twin_s = predict_and_judge(gi, p);
  p.finished_at = utc::now();
  const std::string text = json(p).dump();
  if (!commit_point(p, text)) return;

  const double total_s = seconds_since(t_start);
  r.busy_seconds += total_s;
  {
    std::lock_guard lock(mu_);
    ++points_measured_;
    overhead_ms_.push_back(1000.0 * std::max(0.0, total_s - readings->device_s - twin_s));
    if (overhead_ms_.size() > 1000) overhead_ms_.pop_front();
  }
  publish_point(p, text, gi);
}

// Step 3: the arms to the geometry, the dark, the reference white when due and the sample
// (auto-ranged: autorange.hpp), the arms read back. nullopt: the point was not read, and
// what stopped it is handled (a fault pauses the scan; a requested pause is the loop's).
std::optional<Instrument::PointReadings> Instrument::read_point(const Geometry& g, PointRecord& p) {
  Run& r = *run_;
  const ScanPlan& plan = r.scan.plan;
  PointReadings in;
  const auto timed = [&](auto&& f) {
    beat();
    const auto t0 = Clock::now();
    f();
    in.device_s += seconds_since(t0);
  };
  bool has_rotation = false;
  {
    std::lock_guard lock(mu_);
    has_rotation = std::find(axes_.begin(), axes_.end(), Axis::rotation) != axes_.end();
  }
  Side side = Side::motion;  // whose call failed
  try {
    std::optional<double> rotation;
    if (has_rotation) rotation = g.phi_i;
    timed([&] {
      move_arms(g.theta_i, g.theta_r, rotation);
      if (config_.settle.count() > 0) {
        beat();
        std::this_thread::sleep_for(config_.settle);
      }
    });
    side = Side::photometer;
    // From the nominal setting, shorter while saturated, longer while under-exposed; dark,
    // reference and sample always at one setting.
    const RangeLimits lim{config_.integration_min_ms, config_.integration_max_ms, config_.underexposed_snr};
    if (!r.nominal_ms) timed([&] { r.nominal_ms = nominal_integration_ms(); });
    const bool ranging = *r.nominal_ms > 0;
    const bool due = !r.reference || plan.reads_reference(r.since_start);
    double t = *r.nominal_ms;
    std::optional<double> ceiling;
    std::optional<double> kept;  // the setting of the readings in hand, while ranging further
    for (;;) {
      if (ranging) {
        try {
          timed([&] { set_integration(t); });
        } catch (const Error& e) {
          // The photometer's own limits are narrower than the configured ones.
          if (e.code() != Errc::out_of_range) throw;
          if (ceiling && t < *ceiling)
            throw Error(Errc::saturated,
                        fmt::format("detector saturated at {:g} ms and the photometer refuses a shorter "
                                    "integration time ({}); attenuate the beam",
                                    *ceiling, e.what()));
          if (!kept) throw;
          t = *kept;  // a longer setting refused: keep the readings at the last one
          integration_set_.reset();
          break;
        }
      }
      timed([&] { in.dark = photometer_->measure(Channel::dark, config_.measure_timeout); });
      const bool ref_stale = ranging && r.reference && r.reference->integration_ms > 0 &&
                             std::abs(r.reference->integration_ms - t) > 1e-9 * t;
      const auto policy = ranging ? drivers::SaturationPolicy::flag : drivers::SaturationPolicy::throw_error;
      if (due || ref_stale) {
        drivers::Reading ref;
        timed([&] { ref = photometer_->measure(Channel::reference, config_.measure_timeout, policy); });
        r.reference = std::move(ref);
        r.reference_dark = in.dark;
        in.read_reference = true;
      }
      timed([&] { in.sample = photometer_->measure(Channel::sample, config_.measure_timeout, policy); });
      if (!ranging) break;
      const bool saturated = in.sample.saturated || r.reference->saturated;
      const auto next =
          next_integration_ms(t, saturated, saturated ? 0 : best_channel_snr(in.sample, in.dark), ceiling, lim);
      if (!next) {
        if (saturated) {
          // The shortest setting still saturates: only now a fault, naming the channel.
          throw Error(Errc::saturated,
                      fmt::format("detector saturated on the {} channel at {:g} ms, the shortest "
                                  "integration time allowed (instrument.integration_min_ms); "
                                  "attenuate the beam",
                                  r.reference->saturated ? "reference" : "sample", t));
        }
        break;
      }
      if (saturated) ceiling = t;
      else kept = t;
      spdlog::debug("scan {} point {}: {} at {:g} ms; reading again at {:g} ms", r.scan.id, p.index,
                    saturated ? "saturated" : "under-exposed", t, *next);
      t = *next;
    }
    if (in.sample.integration_ms > 0) p.integration_ms = in.sample.integration_ms;
    else if (ranging) p.integration_ms = t;
    side = Side::motion;
    timed([&] { p.actual.theta_i = motion_->position(Axis::incidence, config_.move_timeout); });
    timed([&] { p.actual.theta_r = motion_->position(Axis::receive, config_.move_timeout); });
    if (has_rotation)
      timed([&] { p.actual.phi_i = p.actual.phi_r = motion_->position(Axis::rotation, config_.move_timeout); });
  } catch (const Error& e) {
    bool stop_requested = false;
    {
      std::lock_guard lock(mu_);
      stop_requested = control_ == Control::pause;
    }
    if (e.code() == Errc::invalid_state && stop_requested) return std::nullopt;  // loop applies the pause
    // The fault pauses the scan; a lost link also closes the device for reopening.
    if (is_link_error(e.code())) drop_device(side, e);
    if (is_device_error(e.code()) || e.code() == Errc::invalid_state) on_device_fault(e);
    else on_device_fault(Error(Errc::device_alarm, e.what()));
    return std::nullopt;
  }
  return in;
}

// Step 4: β and its uncertainty on the plan's grid (point_reduction.hpp), and the reference
// white's drift against the run's first reading. false: a reference not above dark, a
// device fault (handled).
bool Instrument::reduce(const PointReadings& in, PointRecord& p) {
  Run& r = *run_;
  std::optional<ReducedPoint> reduced;
  try {
    reduced = reduce_point(PointSignals{.sample = in.sample.spectrum,
                                        .dark = in.dark.spectrum,
                                        .reference = r.reference->spectrum,
                                        .reference_dark = r.reference_dark->spectrum},
                           r.reference_beta, r.scan.plan.wavelengths);
  } catch (const Error& e) {
    if (e.code() != Errc::protocol_error && e.code() != Errc::device_alarm) throw;
    on_device_fault(e);
    return false;
  }
  p.measured = std::move(reduced->beta);
  if (in.read_reference) p.flags.push_back("reference_read");
  if (in.sample.saturated) p.flags.push_back("saturated");
  if (!in.read_reference) return true;

  // Counts grow with the integration time: the drift compares counts per nominal setting.
  auto net = reduced->net_reference;
  if (r.nominal_ms.value_or(0) > 0 && r.reference->integration_ms > 0)
    for (auto& v : net) v *= *r.nominal_ms / r.reference->integration_ms;
  if (const auto drift = r.drift.observe(net)) {
    p.flags.push_back("reference_drift");
    alerts_.raise(AlertDraft{std::string(alert_kind::reference_drift), Severity::warning,
                             fmt::format("reference_drift:scan:{}", r.scan.id), r.scan.id,
                             r.sample_id, p.index,
                             fmt::format("scan {}: the reference white reading drifted {:.1f} % "
                                         "from its first reading (limit {:.1f} %)",
                                         r.scan.id, 100 * *drift, 100 * r.drift.limit())});
  }
  return true;
}

// Step 5: the twin's prediction, computed ahead, with its uncertainty budget and the
// sample's sensitivities; the point judged by the decision rule (divergence.hpp). Returns
// the seconds spent waiting for the twin (twin time, not the runner's).
double Instrument::predict_and_judge(std::size_t gi, PointRecord& p) {
  Run& r = *run_;
  if (!r.batch) {
    p.flags.push_back("no_prediction");
    return 0;
  }
  beat();
  const auto t0 = Clock::now();
  try {
    auto pp = r.batch->wait(r.adaptive ? 0 : gi);
    p.predicted = pp.prediction.spectrum();
    p.twin_version = r.twin_version;
    p.u_model = pp.budget.u_model;
    p.budget = budget_entries(pp.budget);
    p.sample_sensitivity = std::move(pp.sample);
    if (!pp.prediction.diagnostics.converged) p.flags.push_back("prediction_unconverged");
  } catch (const Error& e) {
    p.flags.push_back("prediction_failed");
    spdlog::warn("scan {} point {}: no prediction: {}", r.scan.id, p.index, e.what());
  }
  const double waited = seconds_since(t0);
  if (p.predicted) {
    const auto d = evaluate_point(p.measured, *p.predicted, p.u_model, p.budget, r.tolerance,
                                  r.colorimeter.get(), divergence_);
    p.z_max = d.z_max;
    p.delta_e00 = d.delta_e00;
    p.color = d.color;
    p.decision = decision_text(d.decision);
    p.diverged = d.diverged;
    if (d.inconsistent) p.flags.push_back("inconsistent");
  }
  return waited;
}

// Step 6: the point committed in one transaction before the next move. false: not stored
// (a storage fault pauses the scan and the point is measured again after the resume; any
// other failure is a fault); a point already stored is skipped, never stored twice.
bool Instrument::commit_point(const PointRecord& p, const std::string& text) {
  Run& r = *run_;
  try {
    store_.insert_point(p, text);
  } catch (const Error& e) {
    if (e.code() == Errc::storage_unavailable) {
      on_storage_fault(e);
      return false;
    }
    if (e.code() != Errc::invalid_state) {
      on_device_fault(Error(Errc::io_error, fmt::format("cannot store point {}: {}", p.index, e.what())));
      return false;
    }
    spdlog::warn("scan {}: {}; skipping it", r.scan.id, e.what());
  }
  ++r.next;
  ++r.since_start;
  return true;
}

// Step 7: the point published, a divergence alert raised, the scan's verdict judged again,
// the adaptive loop told and asked for the next candidate, the progress published; the scan
// completed after its last point.
void Instrument::publish_point(const PointRecord& p, const std::string& text, std::size_t gi) {
  Run& r = *run_;
  hub_.publish_raw(Topic::points, "scan.point", text, r.scan.id);
  if (p.diverged) {
    alerts_.raise(AlertDraft{std::string(alert_kind::divergence), Severity::warning,
                             fmt::format("divergence:scan:{}", r.scan.id), r.scan.id, r.sample_id,
                             p.index,
                             fmt::format("scan {} point {} ({}): out of tolerance (±{:g} %, k = {:g}; "
                                         "max |z| = {:.1f}{})",
                                         r.scan.id, p.index, p.planned.to_string(), 100 * r.tolerance,
                                         divergence_.coverage_k, p.z_max.value_or(0),
                                         p.delta_e00 ? fmt::format(", ΔE00 = {:.2f}", *p.delta_e00)
                                                     : std::string())});
    ++r.scan.points_diverged;
  }
  if (p.predicted) {
    r.evidence.add(p);
    // Judged after every point up to kJudgeEvery points, then after every n/kJudgeEvery-th:
    // a verdict's cost grows with the points (its per-point effects), so a long scan would
    // otherwise slow as it goes; the last point is always judged.
    const auto n = r.evidence.points();
    if (n <= kJudgeEvery || ++r.since_judged * kJudgeEvery >= n) {
      r.since_judged = 0;
      judge_scan(p.index, false);
    }
  }
  if (r.adaptive) {
    r.adaptive->committed(gi, p);
    r.choosing = false;
    if (r.next < r.scan.points_total) r.candidate = r.adaptive->next_after(gi);
    std::lock_guard lock(mu_);
    adaptive_status_ = r.adaptive->status().to_json();
  }
  publish_progress();
  if (r.next >= r.scan.points_total || (r.adaptive && !r.candidate)) {
    judge_scan(p.index, true);
    std::lock_guard sched(sched_mu_);
    finish_adaptive_or_complete(r.next >= r.scan.points_total);
  }
}

void Instrument::finish_adaptive_or_complete(bool at_max_points) {
  Run& r = *run_;
  std::string reason;
  if (r.adaptive) {
    const auto st = r.adaptive->finish(at_max_points);
    auto j = st.to_json();
    {
      std::lock_guard lock(mu_);
      adaptive_status_ = j;
    }
    try {
      store_.insert_fit(r.scan.id, "adaptive", plan_model(r.scan.plan), j, "goniod");
    } catch (const Error& e) {
      spdlog::warn("scan {}: cannot store the adaptive loop's state: {}", r.scan.id, e.what());
    }
    reason = adaptive_summary(st, r.scan.plan);
  }
  finish_run(ScanState::completed, reason, "goniod");
}

void Instrument::judge_scan(std::int64_t point_index, bool final) {
  Run& r = *run_;
  if (r.evidence.points() == 0) return;
  const auto v = r.evidence.verdict();
  const auto key = v.decision + "|" + (v.cause ? v.cause->parameter : std::string());
  // Stored when it changes and at the end: scan.get shows the latest.
  if (key != r.verdict_stored || final) {
    try {
      store_.insert_fit(r.scan.id, "verdict", r.spec, v.to_json(), "goniod");
      r.verdict_stored = key;
    } catch (const Error& e) {
      spdlog::warn("scan {}: cannot store the verdict: {}", r.scan.id, e.what());
    }
  }
  if (v.alerts()) {
    // One alert per scan, updated (not duplicated) as the verdict firms up.
    const auto alert = alerts_.raise(AlertDraft{std::string(alert_kind::sustained), Severity::critical,
                                                fmt::format("sustained:scan:{}", r.scan.id), r.scan.id,
                                                r.sample_id, point_index,
                                                fmt::format("scan {}: {}", r.scan.id, v.summary)});
    // The inverse twin refits the named cause once the whole scan is in.
    if (final && v.cause && sustained_listener_) sustained_listener_(r.scan.id, alert.id);
    if (!r.sustained_raised) {
      r.sustained_raised = true;
      if (config_.pause_on_sustained) {
        std::lock_guard lock(mu_);
        control_ = Control::pause;
        control_reason_ = "sustained divergence from the twin";
        control_actor_ = "goniod";
      }
    }
  }
  if (final && v.calibration_hint) {
    alerts_.raise(AlertDraft{std::string(alert_kind::calibration_hint), Severity::warning,
                             fmt::format("calibration_hint:scan:{}", r.scan.id), r.scan.id, r.sample_id,
                             point_index, fmt::format("scan {}: {}", r.scan.id, v.summary)});
  }
}

void Instrument::publish_progress() {
  const Run& r = *run_;
  const auto remaining = r.scan.points_total - std::min(r.scan.points_total, r.next);
  const double per_point = r.since_start ? r.busy_seconds / static_cast<double>(r.since_start) : 0;
  hub_.publish(Topic::progress, "scan.progress",
               json{{"scan", r.scan.id},
                    {"state", "running"},
                    {"reason", ""},
                    {"points_done", r.next},
                    {"points_total", r.scan.points_total},
                    {"points_diverged", r.scan.points_diverged},
                    {"eta_s", per_point * static_cast<double>(remaining)},
                    {"adaptive", r.adaptive ? adaptive_json() : json(nullptr)}},
               r.scan.id);
}

json Instrument::adaptive_json() const {
  std::lock_guard lock(mu_);
  return adaptive_status_;
}

std::optional<json> Instrument::adaptive_status(std::int64_t scan) const {
  std::lock_guard lock(mu_);
  if (!running_ || *running_ != scan || adaptive_status_.is_null()) return std::nullopt;
  return adaptive_status_;
}

}  // namespace gonio::daemon
