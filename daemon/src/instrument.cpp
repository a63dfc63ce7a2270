// Scheduler and scan runner on the instrument thread (see instrument.hpp).
#include "gonio/daemon/instrument.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/registry/registry.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"

namespace gonio::daemon {

using drivers::Axis;
using drivers::Channel;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

constexpr auto kReopenDelay = std::chrono::seconds(5);

bool is_device_error(Errc c) {
  switch (c) {
    case Errc::timeout:
    case Errc::disconnected:
    case Errc::device_alarm:
    case Errc::protocol_error:
    case Errc::saturated:
    case Errc::busy:
    case Errc::limit_violation:
    case Errc::unsupported: return true;
    default: return false;
  }
}

// Whether opening the devices failed on the driver tables themselves. not_found is one only
// when it names a field (a preset) or a driver that does not exist; otherwise it is a device
// that is not there yet (a serial node udev has not created, a photometer switched off).
bool is_config_error(const Error& e, const Config& c) {
  if (e.code() == Errc::invalid_argument || e.code() == Errc::out_of_range) return true;
  if (e.code() != Errc::not_found) return false;
  if (!e.field().empty()) return true;
  const auto known = [](const json& side) {
    const auto name = side.value("driver", std::string());
    return std::ranges::any_of(drivers::drivers(), [&](const auto& d) { return d.name == name; });
  };
  return !known(c.motion) || !known(c.photometer);
}

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::vector<double> resample(const WavelengthGrid& from, const std::vector<double>& v,
                             const WavelengthGrid& to) {
  if (from == to) return v;
  return interpolate_linear(from.values(), v, to.values());
}

}  // namespace

struct Instrument::Run {
  Scan scan;
  double tolerance = 0;
  std::optional<std::int64_t> sample_id;
  std::shared_ptr<TwinService::Batch> batch;
  std::shared_ptr<const twin::Colorimeter> colorimeter;
  std::string prediction_note;  // why there are no predictions
  std::size_t next = 0;         // next point index to measure
  std::size_t since_start = 0;  // points measured in this run
  std::optional<drivers::Reading> reference, reference_dark;
  std::vector<double> reference_baseline;
  SustainedWindow window{3, 5};
  double busy_seconds = 0;  // wall time of the points of this run (for the ETA)
  bool sustained_raised = false;
};

Instrument::Instrument(const Config& config, Store& store, TwinService& twin, AlertService& alerts,
                       Hub& hub)
    : config_(config), store_(store), twin_(twin), alerts_(alerts), hub_(hub),
      // The one guard, from [instrument.limits]: open_devices() hands it to the registry,
      // which wraps the motion controller with it; plans are validated against it too.
      guard_([&] {
        try {
          return drivers::motion_guard(config.limits, config.motion);
        } catch (const Error& e) {
          throw Error(e.code(), fmt::format("instrument.{}", e.what()),
                      join_field("instrument", e.field()));
        }
      }()) {
  divergence_ = DivergenceSettings{config.z_threshold, config.delta_e_threshold,
                                   config.sustained_m, config.sustained_n, config.reference_drift};
}

Instrument::~Instrument() { shutdown(); }

void Instrument::start() {
  {
    std::lock_guard lock(mu_);
    if (started_) return;
    started_ = true;
  }
  // A bad driver table is a configuration error: fail now, loudly. Absent devices are not:
  // the runner keeps trying.
  open_devices();
  thread_ = std::thread([this] { loop(); });
}

void Instrument::shutdown() {
  {
    std::lock_guard lock(mu_);
    if (stopping_) return;
    stopping_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

std::chrono::steady_clock::time_point Instrument::heartbeat() const {
  return Clock::time_point(Clock::duration(heartbeat_ns_.load()));
}

// Before every bounded wait of the runner thread, so that a healthy thread is never staler
// than its longest single device call (a point makes several, homing one per axis).
void Instrument::beat() { heartbeat_ns_ = Clock::now().time_since_epoch().count(); }

// ---- devices ---------------------------------------------------------------------------

void Instrument::open_devices() {
  try {
    auto inst = drivers::open_instrument(json{{"motion", config_.motion},
                                              {"photometer", config_.photometer}},
                                         guard_);
    const auto axes = inst.motion->axes();
    beat();
    const auto grid = inst.photometer->wavelengths(config_.measure_timeout);
    beat();
    const auto identity = inst.photometer->identify(config_.measure_timeout).to_string();
    std::map<Axis, double> pos;
    for (Axis a : axes) {
      beat();
      pos[a] = inst.motion->position(a, config_.move_timeout);
    }
    {
      std::lock_guard lock(mu_);
      motion_ = std::move(inst.motion);
      photometer_ = std::move(inst.photometer);
      axes_ = axes;
      positions_ = pos;
      photometer_grid_ = grid;
      photometer_identity_ = identity;
      open_error_.clear();
      next_open_attempt_.reset();
    }
    spdlog::info("instrument: motion '{}' ({} axes), photometer '{}' ({} channels, {} nm)",
                 config_.motion.value("driver", "?"), axes.size(),
                 config_.photometer.value("driver", "?"), grid.size(), grid.to_string());
    settle_state();
  } catch (const Error& e) {
    if (is_config_error(e, config_))
      throw Error(e.code(), fmt::format("instrument.{}", e.what()),
                  join_field("instrument", e.field()));
    bool changed = false;
    {
      std::lock_guard lock(mu_);
      changed = open_error_ != e.what();
      open_error_ = e.what();
      next_open_attempt_ = Clock::now() + kReopenDelay;
    }
    if (changed) spdlog::warn("instrument unavailable (retrying every 5 s): {}", e.what());
    set_state("unavailable", e.what());
  }
}

void Instrument::set_state(std::string state, std::string detail) {
  {
    std::lock_guard lock(mu_);
    if (state_ == state && state_detail_ == detail) return;
    state_ = std::move(state);
    state_detail_ = std::move(detail);
  }
  publish_state();
}

void Instrument::settle_state(std::string detail) {
  std::string state;
  {
    std::lock_guard lock(mu_);
    state = fault_latched_ ? "fault" : "idle";
    if (fault_latched_) detail = fault_reason_;
  }
  set_state(std::move(state), std::move(detail));
}

void Instrument::publish_state() { hub_.publish(Topic::state, "instrument.state", status()); }

json Instrument::positions_json() const {
  json p = json::object();
  for (const auto& [axis, deg] : positions_) p[std::string(drivers::axis_name(axis))] = deg;
  return p;
}

json Instrument::status() const {
  std::lock_guard lock(mu_);
  json axes = json::array();
  for (Axis a : axes_) axes.push_back(drivers::axis_name(a));
  return json{
      {"state", state_},
      {"detail", state_detail_},
      {"scan", running_ ? json(*running_) : json(nullptr)},
      {"fault_latched", fault_latched_},
      {"fault_reason", fault_reason_},
      {"available", motion_ != nullptr && photometer_ != nullptr},
      {"error", open_error_},
      {"positions", positions_json()},
      {"axes", std::move(axes)},
      {"motion_driver", config_.motion.value("driver", "")},
      {"photometer_driver", config_.photometer.value("driver", "")},
      {"photometer", {{"identity", photometer_identity_},
                      {"wavelengths", photometer_grid_ ? json(photometer_grid_->to_string())
                                                       : json(nullptr)}}},
      {"limits", {{"incidence", {config_.limits.incidence_min, config_.limits.incidence_max}},
                  {"receive", {config_.limits.receive_min, config_.limits.receive_max}},
                  {"min_separation", guard_.min_separation_deg()}}},
  };
}

json Instrument::stats() const {
  std::lock_guard lock(mu_);
  // system.info is polled far more often than points are measured.
  if (stats_cache_ && stats_cache_->first == points_measured_) return stats_cache_->second;
  std::vector<double> v(overhead_ms_.begin(), overhead_ms_.end());
  std::sort(v.begin(), v.end());
  const auto q = [&](double f) {
    return v.empty() ? json(nullptr)
                     : json(v[std::min(v.size() - 1, static_cast<std::size_t>(f * static_cast<double>(v.size())))]);
  };
  json out{{"points_measured", points_measured_},
           {"overhead_ms_p50", q(0.5)},
           {"overhead_ms_p99", q(0.99)},
           {"overhead_ms_max", v.empty() ? json(nullptr) : json(v.back())},
           {"overhead_window", v.size()}};
  stats_cache_ = std::make_pair(points_measured_, out);
  return out;
}

// ---- the loop ----------------------------------------------------------------------------

void Instrument::wake() { cv_.notify_all(); }

std::optional<std::int64_t> Instrument::running_scan() const {
  std::lock_guard lock(mu_);
  return running_;
}

void Instrument::loop() {
  for (;;) {
    beat();
    std::unique_lock lock(mu_);
    if (stopping_) break;
    if (!commands_.empty()) {
      auto cmd = commands_.front();
      commands_.pop_front();
      lock.unlock();
      try {
        cmd->done.set_value(cmd->fn());
      } catch (...) {
        cmd->done.set_exception(std::current_exception());
      }
      continue;
    }
    if (!motion_ || !photometer_) {
      const auto at = next_open_attempt_.value_or(Clock::now());
      if (Clock::now() >= at) {
        lock.unlock();
        try {
          open_devices();
        } catch (const Error& e) {
          spdlog::error("instrument: {}", e.what());
          std::lock_guard l2(mu_);
          next_open_attempt_ = Clock::now() + kReopenDelay;
        }
        continue;
      }
      cv_.wait_until(lock, at);
      continue;
    }
    if (run_) {
      if (control_ != Control::none) {
        const auto c = control_;
        const auto reason = control_reason_, actor = control_actor_;
        control_ = Control::none;
        lock.unlock();
        finish_run(c == Control::pause ? ScanState::paused : ScanState::cancelled, reason, actor);
        continue;
      }
      lock.unlock();
      try {
        step();
      } catch (const std::exception& e) {
        // A bug, not a device: fail the scan rather than the daemon.
        std::int64_t id = 0;
        {
          std::lock_guard l2(mu_);
          id = run_ ? run_->scan.id : 0;
        }
        spdlog::error("scan {}: internal error: {}", id, e.what());
        alerts_.raise(AlertDraft{std::string(alert_kind::scan_failed), Severity::critical,
                                 fmt::format("scan_failed:scan:{}", id), id, std::nullopt,
                                 std::nullopt, fmt::format("scan {} failed: {}", id, e.what())});
        std::lock_guard sched(sched_mu_);
        finish_run(ScanState::failed, fmt::format("internal error: {}", e.what()), "goniod");
      }
      continue;
    }
    if (auto_resume_ && Clock::now() >= auto_resume_->second) {
      const auto id = auto_resume_->first;
      auto_resume_.reset();
      lock.unlock();
      try {
        resume(id, "goniod (auto-resume)");
        spdlog::info("scan {}: resumed automatically after a device fault", id);
      } catch (const Error& e) {
        spdlog::warn("scan {}: auto-resume failed: {}", id, e.what());
      }
      continue;
    }
    auto wait_until = Clock::now() + std::chrono::seconds(1);
    if (auto_resume_) wait_until = std::min(wait_until, auto_resume_->second);
    if (!fault_latched_) {
      lock.unlock();
      std::optional<Scan> next;
      {
        std::lock_guard sched(sched_mu_);
        try {
          next = store_.next_runnable(utc::now());
          if (next) start_run(*next);
        } catch (const Error& e) {
          spdlog::error("scheduler: {}", e.what());
        }
      }
      if (next) continue;
      lock.lock();
      if (stopping_ || !commands_.empty()) continue;
    }
    cv_.wait_until(lock, wait_until);
  }
  // Park: the point in progress has been committed (step() returns only after that).
  bool parked = false;
  {
    std::lock_guard lock(mu_);
    parked = run_ != nullptr;
  }
  if (parked) {
    std::lock_guard sched(sched_mu_);
    const auto next = run_->next;
    finish_run(ScanState::interrupted,
               fmt::format("goniod stopped; resumes at point {} of {}", next,
                           run_->scan.points_total),
               "goniod");
  }
  std::deque<std::shared_ptr<Command>> pending;
  {
    std::lock_guard lock(mu_);
    pending.swap(commands_);
  }
  for (auto& c : pending)
    c->done.set_exception(std::make_exception_ptr(Error(Errc::invalid_state, "goniod is stopping")));
}

// ---- runs ------------------------------------------------------------------------------

void Instrument::start_run(const Scan& scan) {
  auto r = std::make_unique<Run>();
  r->scan = scan;
  r->window = SustainedWindow(config_.sustained_m, config_.sustained_n);
  r->next = static_cast<std::size_t>(store_.next_point_index(scan.id));
  const auto sample = store_.sample(scan.plan.sample_id);
  r->tolerance = sample ? sample->spec.tolerance : 0;
  r->sample_id = scan.plan.sample_id;
  if (!sample || !sample->spec.bsdf) {
    r->prediction_note = "the sample has no reference BSDF: measured without predictions";
  } else {
    try {
      auto tw = twin_.make(*sample->spec.bsdf, scan.plan.wavelengths, "sample.bsdf");
      if (r->next < scan.points_total)
        r->batch = twin_.batch(std::move(tw), scan.plan.geometries, scan.plan.geometry_index(r->next));
    } catch (const Error& e) {
      r->prediction_note = fmt::format("no predictions: {}", e.what());
      spdlog::warn("scan {}: {}", scan.id, r->prediction_note);
    }
  }
  r->colorimeter = colorimeter_for(scan.plan.wavelengths);
  const auto resumed = r->next > 0;
  store_.set_scan_state(scan.id, ScanState::running,
                        resumed ? fmt::format("resumed at point {}", r->next) : std::string(),
                        "goniod");
  r->scan.state = ScanState::running;
  spdlog::info("scan {}: {} ({} points{}){}", scan.id, resumed ? "resumed" : "started",
               scan.points_total, resumed ? fmt::format(", from point {}", r->next) : "",
               r->prediction_note.empty() ? "" : "; " + r->prediction_note);
  {
    std::lock_guard lock(mu_);
    run_ = std::move(r);
    running_ = scan.id;
    control_ = Control::none;
  }
  set_state("scanning", fmt::format("scan {}", scan.id));
  hub_.publish(Topic::state, "scan.state",
               json{{"scan", scan.id}, {"state", "running"}, {"reason", ""}}, scan.id);
  if (status_listener_) status_listener_(fmt::format("scan {} running", scan.id));
  // A scan whose every point is stored (crash after the last commit) completes at once.
  if (run_->next >= scan.points_total) finish_run(ScanState::completed, "", "goniod");
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
  try {
    store_.set_scan_state(r->scan.id, state, reason, actor);
  } catch (const Error& e) {
    spdlog::error("scan {}: cannot record state {}: {}", r->scan.id, to_string(state), e.what());
  }
  const auto sc = store_.scan(r->scan.id);
  spdlog::info("scan {}: {}{}", r->scan.id, to_string(state), reason.empty() ? "" : ": " + reason);
  hub_.publish(Topic::state, "scan.state",
               json{{"scan", r->scan.id}, {"state", to_string(state)}, {"reason", reason}},
               r->scan.id);
  if (sc)
    hub_.publish(Topic::progress, "scan.progress",
                 json{{"scan", sc->id},
                      {"state", to_string(sc->state)},
                      {"reason", sc->reason},
                      {"points_done", sc->points_done},
                      {"points_total", sc->points_total},
                      {"points_diverged", sc->points_diverged},
                      {"eta_s", 0.0}},
                 sc->id);
  settle_state();
  if (status_listener_)
    status_listener_(fmt::format("scan {} {}", r->scan.id, to_string(state)));
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

void Instrument::step() {
  Run& r = *run_;
  const ScanPlan& plan = r.scan.plan;
  const std::size_t idx = r.next;
  const std::size_t gi = plan.geometry_index(idx);
  const Geometry& g = plan.geometries[gi];
  const auto t_start = Clock::now();
  double device_s = 0, twin_s = 0;
  const auto timed = [&](auto&& f) {
    beat();
    const auto t0 = Clock::now();
    f();
    device_s += seconds_since(t0);
  };

  PointRecord p;
  p.scan_id = r.scan.id;
  p.index = static_cast<std::int64_t>(idx);
  p.geometry_index = static_cast<std::int64_t>(gi);
  p.repeat = static_cast<int>(idx % static_cast<std::size_t>(plan.repeats));
  p.planned = g;
  p.started_at = utc::now();
  drivers::Reading dark, sample;
  bool read_reference = false;
  bool has_rotation = false;
  {
    std::lock_guard lock(mu_);
    has_rotation = std::find(axes_.begin(), axes_.end(), Axis::rotation) != axes_.end();
  }
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
    timed([&] { dark = photometer_->measure(Channel::dark, config_.measure_timeout); });
    read_reference = !r.reference || plan.reads_reference(r.since_start);
    if (read_reference) {
      drivers::Reading ref;
      timed([&] { ref = photometer_->measure(Channel::reference, config_.measure_timeout); });
      r.reference = std::move(ref);
      r.reference_dark = dark;
    }
    timed([&] { sample = photometer_->measure(Channel::sample, config_.measure_timeout); });
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
    if (e.code() == Errc::invalid_state && stop_requested) return;  // loop applies the pause
    if (is_device_error(e.code()) || e.code() == Errc::invalid_state) {
      on_device_fault(e);
      return;
    }
    on_device_fault(Error(Errc::device_alarm, e.what()));
    return;
  }

  // β = β_ref (S − D) / (R − D_R) per channel, first-order uncertainty.
  const auto& grid = sample.spectrum.wavelengths;
  const auto& S = sample.spectrum;
  const auto& D = dark.spectrum;
  const auto& R = r.reference->spectrum;
  const auto& DR = r.reference_dark->spectrum;
  const double beta_ref = twin_.profile().reference_beta;
  std::vector<double> beta(S.size()), u(S.size()), net_ref(S.size());
  if (D.size() != S.size() || R.size() != S.size() || DR.size() != S.size()) {
    on_device_fault(Error(Errc::protocol_error, "readings of one point have different channel counts"));
    return;
  }
  for (std::size_t c = 0; c < S.size(); ++c) {
    const double ns = S.values[c] - D.values[c];
    const double nr = R.values[c] - DR.values[c];
    net_ref[c] = nr;
    if (!(nr > 0)) {
      on_device_fault(Error(Errc::device_alarm,
                            fmt::format("the reference signal is not above dark at {:g} nm (is "
                                        "the lamp on?)",
                                        grid[c])));
      return;
    }
    beta[c] = beta_ref * ns / nr;
    const double us2 = S.std_uncertainty[c] * S.std_uncertainty[c] + D.std_uncertainty[c] * D.std_uncertainty[c];
    const double ur2 = R.std_uncertainty[c] * R.std_uncertainty[c] + DR.std_uncertainty[c] * DR.std_uncertainty[c];
    u[c] = std::sqrt(us2 * (beta_ref / nr) * (beta_ref / nr) + ur2 * (beta[c] / nr) * (beta[c] / nr));
  }
  p.measured = Spectrum(plan.wavelengths, resample(grid, beta, plan.wavelengths),
                        resample(grid, u, plan.wavelengths));
  if (read_reference) p.flags.push_back("reference_read");
  if (sample.saturated) p.flags.push_back("saturated");

  // Reference white drift against the run's first reading (instrument health).
  if (read_reference) {
    if (r.reference_baseline.empty()) {
      r.reference_baseline = net_ref;
    } else if (const auto drift = reference_drift(r.reference_baseline, net_ref);
               drift && *drift > divergence_.reference_drift) {
      p.flags.push_back("reference_drift");
      alerts_.raise(AlertDraft{std::string(alert_kind::reference_drift), Severity::warning,
                               fmt::format("reference_drift:scan:{}", r.scan.id), r.scan.id,
                               r.sample_id, p.index,
                               fmt::format("scan {}: the reference white reading drifted {:.1f} % "
                                           "from its first reading (limit {:.1f} %)",
                                           r.scan.id, 100 * *drift,
                                           100 * divergence_.reference_drift)});
    }
  }

  // The twin's prediction, computed ahead; waiting for it is twin time, not ours.
  if (r.batch) {
    beat();
    const auto t0 = Clock::now();
    try {
      const auto pred = r.batch->wait(gi);
      p.predicted = pred.spectrum();
      p.twin_version = twin_.version();
      if (!pred.diagnostics.converged) p.flags.push_back("prediction_unconverged");
    } catch (const Error& e) {
      p.flags.push_back("prediction_failed");
      spdlog::warn("scan {} point {}: no prediction: {}", r.scan.id, idx, e.what());
    }
    twin_s += seconds_since(t0);
  } else {
    p.flags.push_back("no_prediction");
  }

  if (p.predicted) {
    const auto d = evaluate_point(p.measured, *p.predicted, r.tolerance, r.colorimeter.get(), divergence_);
    p.z_max = d.z_max;
    p.delta_e00 = d.delta_e00;
    p.diverged = d.diverged;
  }
  p.finished_at = utc::now();

  // Commit before the next move.
  const std::string point_text = json(p).dump();
  try {
    store_.insert_point(p, point_text);
  } catch (const Error& e) {
    if (e.code() == Errc::invalid_state) {
      spdlog::warn("scan {}: {}; skipping it", r.scan.id, e.what());  // never store twice
    } else {
      on_device_fault(Error(Errc::io_error, fmt::format("cannot store point {}: {}", idx, e.what())));
      return;
    }
  }
  ++r.next;
  ++r.since_start;
  const double total_s = seconds_since(t_start);
  r.busy_seconds += total_s;
  {
    std::lock_guard lock(mu_);
    ++points_measured_;
    overhead_ms_.push_back(1000.0 * std::max(0.0, total_s - device_s - twin_s));
    if (overhead_ms_.size() > 1000) overhead_ms_.pop_front();
  }

  hub_.publish_raw(Topic::points, "scan.point", point_text, r.scan.id);
  if (p.diverged) {
    alerts_.raise(AlertDraft{std::string(alert_kind::divergence), Severity::warning,
                             fmt::format("divergence:scan:{}", r.scan.id), r.scan.id, r.sample_id,
                             p.index,
                             fmt::format("scan {} point {} ({}): measured and predicted differ "
                                         "(max |z| = {:.1f}{})",
                                         r.scan.id, idx, g.to_string(), p.z_max.value_or(0),
                                         p.delta_e00 ? fmt::format(", ΔE00 = {:.2f}", *p.delta_e00)
                                                     : std::string())});
  }
  if (p.predicted && r.window.push(p.diverged) && !r.sustained_raised) {
    r.sustained_raised = true;
    alerts_.raise(AlertDraft{std::string(alert_kind::sustained), Severity::critical,
                             fmt::format("sustained:scan:{}", r.scan.id), r.scan.id, r.sample_id,
                             p.index,
                             fmt::format("scan {}: {} of the last {} points diverge from the twin "
                                         "(up to point {})",
                                         r.scan.id, r.window.diverged_in_window(),
                                         config_.sustained_n, idx)});
    if (config_.pause_on_sustained) {
      std::lock_guard lock(mu_);
      control_ = Control::pause;
      control_reason_ = "sustained divergence from the twin";
      control_actor_ = "goniod";
    }
  }
  if (p.diverged) ++r.scan.points_diverged;
  publish_progress();
  if (r.next >= r.scan.points_total) {
    std::lock_guard sched(sched_mu_);
    finish_run(ScanState::completed, "", "goniod");
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
                    {"eta_s", per_point * static_cast<double>(remaining)}},
               r.scan.id);
}

// ---- scheduler operations ---------------------------------------------------------------

Scan Instrument::pause(std::int64_t id, const std::string& actor, const std::string& reason) {
  std::unique_lock sched(sched_mu_);
  auto sc = store_.scan(id);
  if (!sc) throw Error(Errc::not_found, fmt::format("scan {} does not exist", id), "scan");
  {
    std::unique_lock lock(mu_);
    if (running_ == id) {
      control_ = Control::pause;
      control_reason_ = reason.empty() ? fmt::format("paused by {}", actor) : reason;
      control_actor_ = actor;
      sched.unlock();
      cv_.notify_all();
      cv_.wait_for(lock, std::chrono::seconds(60), [&] { return running_ != id; });
      lock.unlock();
      return *store_.scan(id);
    }
  }
  if (sc->state == ScanState::paused) return *sc;
  if (sc->state != ScanState::queued && sc->state != ScanState::interrupted)
    throw Error(Errc::invalid_state,
                fmt::format("scan {} is {}; only queued, running or interrupted scans can be "
                            "paused",
                            id, to_string(sc->state)),
                "scan");
  store_.set_scan_state(id, ScanState::paused,
                        reason.empty() ? fmt::format("paused by {}", actor) : reason, actor);
  hub_.publish(Topic::state, "scan.state", json{{"scan", id}, {"state", "paused"}, {"reason", reason}}, id);
  return *store_.scan(id);
}

Scan Instrument::resume(std::int64_t id, const std::string& actor) {
  std::lock_guard sched(sched_mu_);
  auto sc = store_.scan(id);
  if (!sc) throw Error(Errc::not_found, fmt::format("scan {} does not exist", id), "scan");
  if (sc->state != ScanState::paused)
    throw Error(Errc::invalid_state,
                fmt::format("scan {} is {}; only paused scans can be resumed{}", id,
                            to_string(sc->state),
                            sc->state == ScanState::interrupted ? " (interrupted ones resume by "
                                                                  "themselves)"
                                                                : ""),
                "scan");
  store_.set_scan_state(id, ScanState::queued, fmt::format("resumed by {}", actor), actor);
  {
    std::lock_guard lock(mu_);
    // A technician's resume is the acknowledgement that the instrument is fit again.
    fault_latched_ = false;
    fault_reason_.clear();
    if (auto_resume_ && auto_resume_->first == id) auto_resume_.reset();
  }
  hub_.publish(Topic::state, "scan.state", json{{"scan", id}, {"state", "queued"}, {"reason", ""}}, id);
  cv_.notify_all();
  return *store_.scan(id);
}

Scan Instrument::cancel(std::int64_t id, const std::string& actor, const std::string& reason) {
  std::unique_lock sched(sched_mu_);
  auto sc = store_.scan(id);
  if (!sc) throw Error(Errc::not_found, fmt::format("scan {} does not exist", id), "scan");
  const auto why = reason.empty() ? fmt::format("cancelled by {}", actor) : reason;
  {
    std::unique_lock lock(mu_);
    if (running_ == id) {
      control_ = Control::cancel;
      control_reason_ = why;
      control_actor_ = actor;
      sched.unlock();
      cv_.notify_all();
      cv_.wait_for(lock, std::chrono::seconds(60), [&] { return running_ != id; });
      lock.unlock();
      return *store_.scan(id);
    }
  }
  if (is_final(sc->state))
    throw Error(Errc::invalid_state,
                fmt::format("scan {} is already {}", id, to_string(sc->state)), "scan");
  store_.set_scan_state(id, ScanState::cancelled, why, actor);
  hub_.publish(Topic::state, "scan.state", json{{"scan", id}, {"state", "cancelled"}, {"reason", why}}, id);
  return *store_.scan(id);
}

void Instrument::validate_plan(const ScanPlan& plan) const {
  std::optional<WavelengthGrid> grid;
  bool know_axes = false, has_rotation = false;
  {
    std::lock_guard lock(mu_);
    grid = photometer_grid_;
    know_axes = !axes_.empty();
    has_rotation = std::find(axes_.begin(), axes_.end(), Axis::rotation) != axes_.end();
  }
  const auto reject = [](std::size_t k, const Geometry& g, const std::string& why) {
    const auto field = fmt::format("geometries[{}]", k);
    return Error(Errc::plan_rejected, fmt::format("{} ({}): {}", field, g.to_string(), why), field);
  };
  const double sep = guard_.min_separation_deg();
  for (std::size_t k = 0; k < plan.geometries.size(); ++k) {
    const auto& g = plan.geometries[k];
    if (g.phi_i != g.phi_r)
      throw reject(k, g, "out-of-plane geometries with φi ≠ φr need a tilt axis, which this "
                         "instrument does not drive");
    if (g.phi_i != 0 && know_axes && !has_rotation)
      throw reject(k, g, "an azimuth needs the sample rotation axis, which this instrument "
                         "does not have");
    try {
      guard_.check_limits(Axis::incidence, g.theta_i);
      guard_.check_limits(Axis::receive, g.theta_r);
    } catch (const Error& e) {
      throw reject(k, g, e.what());
    }
    const double s = drivers::MotionGuard::arm_separation(g.theta_i, g.theta_r);
    if (s < sep)
      throw reject(k, g, fmt::format("the arms would be {:g}° apart, inside the collision zone "
                                     "(minimum separation {:g}°)",
                                     s, sep));
    if (k > 0) {
      const auto& prev = plan.geometries[k - 1];
      const auto ok = [&](bool incidence_first) {
        try {
          if (incidence_first) {
            guard_.check_move(Axis::incidence, prev.theta_i, g.theta_i, prev.theta_r);
            guard_.check_move(Axis::receive, prev.theta_r, g.theta_r, g.theta_i);
          } else {
            guard_.check_move(Axis::receive, prev.theta_r, g.theta_r, prev.theta_i);
            guard_.check_move(Axis::incidence, prev.theta_i, g.theta_i, g.theta_r);
          }
          return true;
        } catch (const Error&) {
          return false;
        }
      };
      if (!ok(true) && !ok(false))
        throw reject(k, g, fmt::format("the arms cannot move here from {} without entering the "
                                       "collision zone (minimum separation {:g}°)",
                                       prev.to_string(), sep));
    }
  }
  if (grid && !grid->empty()) {
    const double lo = grid->values().front(), hi = grid->values().back();
    const double a = plan.wavelengths.values().front(), b = plan.wavelengths.values().back();
    if (a < lo - 1e-9 || b > hi + 1e-9)
      throw Error(Errc::plan_rejected,
                  fmt::format("wavelengths: {:g}–{:g} nm is outside the photometer's range "
                              "{:g}–{:g} nm",
                              a, b, lo, hi),
                  "wavelengths");
  }
}

// ---- commands --------------------------------------------------------------------------

json Instrument::submit(std::function<json()> fn) {
  auto cmd = std::make_shared<Command>();
  cmd->fn = std::move(fn);
  auto fut = cmd->done.get_future();
  {
    std::lock_guard lock(mu_);
    if (stopping_) throw Error(Errc::invalid_state, "goniod is stopping");
    if (running_)
      throw Error(Errc::busy,
                  fmt::format("the instrument is running scan {}; pause it first", *running_));
    if (!motion_ || !photometer_)
      throw Error(Errc::disconnected, fmt::format("the instrument is unavailable: {}", open_error_));
    commands_.push_back(cmd);
  }
  cv_.notify_all();
  return fut.get();
}

json Instrument::home(std::vector<Axis> axes, const std::string& actor) {
  return submit([this, axes, actor]() mutable {
    if (axes.empty()) {
      std::lock_guard lock(mu_);
      axes = axes_;
    }
    store_.audit(actor, "instrument.home", "", json{{"axes", [&] {
                                                      json a = json::array();
                                                      for (Axis x : axes) a.push_back(drivers::axis_name(x));
                                                      return a;
                                                    }()}});
    set_state("homing");
    try {
      for (Axis a : axes) {
        beat();
        motion_->home(a, config_.home_timeout);
        beat();
        const double pos = motion_->position(a, config_.move_timeout);
        std::lock_guard lock(mu_);
        positions_[a] = pos;
      }
    } catch (const Error& e) {
      settle_state(e.what());
      throw;
    }
    settle_state();
    return status();
  });
}

json Instrument::move(const std::map<Axis, double>& targets, const std::string& actor) {
  // Limits and the collision zone are checked before the instrument thread is bothered.
  for (const auto& [axis, deg] : targets) guard_.check_limits(axis, deg);
  return submit([this, targets, actor] {
    json detail = json::object();
    for (const auto& [axis, deg] : targets) detail[std::string(drivers::axis_name(axis))] = deg;
    store_.audit(actor, "instrument.move", "", detail);
    double i = 0, r = 0;
    {
      std::lock_guard lock(mu_);
      i = positions_.contains(Axis::incidence) ? positions_[Axis::incidence] : 0;
      r = positions_.contains(Axis::receive) ? positions_[Axis::receive] : 0;
    }
    const auto ti = targets.contains(Axis::incidence) ? targets.at(Axis::incidence) : i;
    const auto tr = targets.contains(Axis::receive) ? targets.at(Axis::receive) : r;
    set_state("moving");
    try {
      if (targets.contains(Axis::incidence) || targets.contains(Axis::receive))
        move_arms(ti, tr, std::nullopt);
      for (const auto& [axis, deg] : targets) {
        if (axis == Axis::incidence || axis == Axis::receive) continue;
        beat();
        motion_->move(axis, deg, config_.move_timeout);
        std::lock_guard lock(mu_);
        positions_[axis] = deg;
      }
    } catch (const Error& e) {
      settle_state(e.what());
      throw;
    }
    settle_state();
    return status();
  });
}

json Instrument::reset(const std::string& actor) {
  return submit([this, actor] {
    store_.audit(actor, "instrument.reset", "", json::object());
    std::vector<Axis> axes;
    {
      std::lock_guard lock(mu_);
      axes = axes_;
    }
    if (motion_->capabilities().alarm_reset)
      for (Axis a : axes) {
        beat();
        motion_->reset_alarm(a, config_.move_timeout);
      }
    {
      std::lock_guard lock(mu_);
      fault_latched_ = false;
      fault_reason_.clear();
    }
    set_state("idle");
    cv_.notify_all();
    return status();
  });
}

json Instrument::stop(const std::string& actor) {
  std::optional<std::int64_t> scan;
  {
    std::lock_guard lock(mu_);
    if (!motion_) throw Error(Errc::disconnected, fmt::format("the instrument is unavailable: {}", open_error_));
    motion_->stop(std::chrono::milliseconds(2000));
    if (running_) {
      scan = running_;
      control_ = Control::pause;
      control_reason_ = fmt::format("stopped by {}", actor);
      control_actor_ = actor;
    }
  }
  cv_.notify_all();
  store_.audit(actor, "instrument.stop", scan ? fmt::format("scan:{}", *scan) : "", json::object());
  spdlog::warn("instrument: stopped by {}{}", actor, scan ? fmt::format(" (scan {} pauses)", *scan) : "");
  return json{{"stopped", true}, {"scan", scan ? json(*scan) : json(nullptr)}};
}

}  // namespace gonio::daemon
