// Instrument, part 1: the runner thread and its loop (manual commands, device reopening,
// scheduling, parking the running scan at shutdown), the devices and the instrument's state
// and statistics (see instrument.hpp). Runs are in run.cpp, scheduler control and
// manual commands in commands.cpp.
#include "gonio/daemon/instrument/instrument.hpp"

#include <algorithm>
#include <utility>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/rpc/governor.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/json_writer.hpp"
#include "gonio/proto/text.hpp"
#include "gonio/registry/registry.hpp"
#include "instrument/scan_run.hpp"

namespace gonio::daemon {

using drivers::Axis;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

// The reads that check a device just opened: short, so that a device that is not there
// (a Modbus link retrying its connection until the deadline) does not hold the runner, and
// a shutdown, for a whole move timeout.
constexpr std::chrono::milliseconds kOpenReadTimeout{5000};

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

}  // namespace

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
      }()),
      storage_(store, alerts),
      ranger_(AutoRanger::Settings{.enabled = config.autorange,
                                   .integration_ms = config.integration_ms,
                                   .limits = RangeLimits{config.integration_min_ms, config.integration_max_ms,
                                                         config.underexposed_snr},
                                   .timeout = config.measure_timeout},
              [this] { beat(); }),
      arms_(guard_, ArmMover::Timeouts{.move = config.move_timeout, .home = config.home_timeout}, [this] { beat(); },
            [this](const ArmStep& s, double deg) {
              std::lock_guard lock(mu_);
              positions_[s.axis] = deg;
              if (s.kind == ArmStep::Kind::home) std::erase(unhomed_, s.axis);
            }) {
  divergence_ = DivergenceSettings{.coverage_k = config.coverage_k,
                                   .z_threshold = config.z_threshold,
                                   .delta_e_threshold = config.delta_e_threshold,
                                   .delta_uv_threshold = config.delta_uv_threshold,
                                   .reference_drift = config.reference_drift};
}

Instrument::~Instrument() { shutdown(); }

void Instrument::start() {
  {
    std::lock_guard lock(mu_);
    if (started_) return;
    started_ = true;
  }
  restore_fault_latch();
  // A bad driver table is a configuration error: fail now, loudly. Absent devices are not:
  // the runner keeps trying.
  open_devices(true);
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

void Instrument::restore_fault_latch() {
  AlertFilter f;
  f.acknowledged = false;
  f.min_severity = Severity::critical;
  f.limit = 1000;
  for (const auto& a : store_.alerts(f)) {
    if (a.kind != alert_kind::device_fault) continue;
    std::lock_guard lock(mu_);
    fault_latched_ = true;
    fault_reason_ = fmt::format("{} (alert {}, unacknowledged since before this start)", a.message, a.id);
    spdlog::warn("instrument: fault latched from alert {} ({}): nothing runs until a technician "
                 "resumes a scan or resets the instrument",
                 a.id, a.message);
    return;  // the newest one names the fault
  }
}

void Instrument::acknowledge_faults(const std::string& actor) {
  AlertFilter f;
  f.acknowledged = false;
  f.min_severity = Severity::critical;
  f.limit = 1000;
  for (const auto& a : store_.alerts(f))
    if (a.kind == alert_kind::device_fault) alerts_.ack(a.id, actor);
}

// ---- devices ---------------------------------------------------------------------------

void Instrument::open_devices(bool at_start) {
  // The photometer first: an absent one fails at once, while a motion controller's link
  // may retry until its read times out.
  for (const Side s : {Side::photometer, Side::motion}) {
    {
      std::lock_guard lock(mu_);
      const Link& l = link(s);
      if (l.up || (l.next_retry && *l.next_retry > Clock::now())) continue;
    }
    open_side(s, at_start);
  }
  settle_state();
}

void Instrument::open_side(Side s, bool at_start) {
  const char* name = s == Side::motion ? "motion" : "photometer";
  try {
    if (!opener_)
      opener_ = std::make_unique<drivers::InstrumentOpener>(
          json{{"motion", config_.motion}, {"photometer", config_.photometer}}, guard_);
    if (s == Side::motion) {
      auto m = opener_->open_motion();
      const auto axes = m->axes();
      const bool can_home = m->capabilities().homing;
      std::map<Axis, double> pos;
      for (Axis a : axes) {
        beat();
        pos[a] = m->position(a, std::min(config_.move_timeout, kOpenReadTimeout));
      }
      std::unique_ptr<drivers::MotionController> old;
      std::lock_guard lock(mu_);
      Link& l = link(s);
      // A controller that reconnects may have rebooted and lost its position: what it
      // reports is not trusted for a move until each axis is homed again.
      if (l.ever_up && can_home) unhomed_ = axes;
      old = std::exchange(motion_, std::move(m));
      axes_ = axes;
      positions_ = pos;
    } else {
      auto p = opener_->open_photometer();
      beat();
      const auto grid = p->wavelengths(std::min(config_.measure_timeout, kOpenReadTimeout));
      beat();
      const auto identity = p->identify(std::min(config_.measure_timeout, kOpenReadTimeout)).to_string();
      std::unique_ptr<drivers::Photometer> old;
      std::lock_guard lock(mu_);
      Link& l = link(s);
      if (l.ever_up && (identity != photometer_identity_ || !photometer_grid_ || grid != *photometer_grid_)) {
        // Another device on the same port: the paused scan was planned for the old one.
        fault_latched_ = true;
        fault_reason_ = fmt::format("the photometer that came back is not the one that went away "
                                    "(was {}, {} nm; now {}, {} nm): check it, then resume",
                                    photometer_identity_,
                                    photometer_grid_ ? photometer_grid_->to_string() : "?",
                                    identity, grid.to_string());
        auto_resume_.reset();
        spdlog::error("instrument: {}", fault_reason_);
      }
      old = std::exchange(photometer_, std::move(p));
      ranger_.reopened();  // a device opened again may have any setting
      photometer_grid_ = grid;
      photometer_identity_ = identity;
    }
    bool again = false;
    {
      std::lock_guard lock(mu_);
      Link& l = link(s);
      again = l.ever_up;
      if (again) ++l.reconnects;
      l.up = l.ever_up = true;
      l.failures = 0;
      l.next_retry.reset();
      l.wait = config_.reconnect_initial;
    }
    if (s == Side::motion)
      spdlog::info("instrument: motion '{}' {} ({} axes){}", config_.motion.value("driver", "?"),
                   again ? "reconnected" : "open", axes_.size(),
                   again && !unhomed_.empty() ? "; home every axis before moving" : "");
    else
      spdlog::info("instrument: photometer '{}' {} ({}; {} channels, {} nm)",
                   config_.photometer.value("driver", "?"), again ? "reconnected" : "open",
                   photometer_identity_, photometer_grid_->size(), photometer_grid_->to_string());
  } catch (const Error& e) {
    if (is_config_error(e, config_)) {
      const Error named(e.code(), fmt::format("instrument.{}", e.what()),
                        join_field("instrument", e.field()));
      if (at_start) throw named;
      spdlog::error("instrument: {}", named.what());
    }
    std::chrono::milliseconds wait{};
    bool changed = false;
    {
      std::lock_guard lock(mu_);
      Link& l = link(s);
      changed = l.error != e.what();
      l.up = false;
      l.error = e.what();
      l.errc = std::string(e.id());
      l.error_at = utc::now();
      ++l.failures;
      if (l.wait.count() <= 0) l.wait = config_.reconnect_initial;
      wait = l.wait;
      l.next_retry = Clock::now() + wait;
      l.wait = std::min(l.wait * 2, config_.reconnect_max);
    }
    if (changed) spdlog::warn("instrument: {} unavailable (next attempt in {} ms): {}", name,
                              wait.count(), e.what());
  }
}

void Instrument::drop_device(Side s, const Error& e) {
  std::unique_ptr<drivers::MotionController> m;
  std::unique_ptr<drivers::Photometer> p;
  {
    std::lock_guard lock(mu_);
    Link& l = link(s);
    if (!l.up) return;
    if (s == Side::motion) m = std::move(motion_);
    else p = std::move(photometer_);
    l.up = false;
    l.error = e.what();
    l.errc = std::string(e.id());
    l.error_at = utc::now();
    l.failures = 0;
    l.next_retry = Clock::now() + config_.reconnect_initial;
    l.wait = std::min(config_.reconnect_initial * 2, config_.reconnect_max);
  }
  spdlog::warn("instrument: {} link lost ({}); reopening in {} ms",
               s == Side::motion ? "motion" : "photometer", e.what(),
               config_.reconnect_initial.count());
  // The old handles are closed here, outside the lock.
}

json Instrument::link_json(Side s) const {
  const Link& l = link(s);
  json next = nullptr;
  if (!l.up && l.next_retry)
    next = std::max(0.0, std::chrono::duration<double>(*l.next_retry - Clock::now()).count());
  return json{{"driver", (s == Side::motion ? config_.motion : config_.photometer).value("driver", "")},
              {"link", l.up ? "up" : "down"},
              {"last_error", l.error},
              {"last_errc", l.errc},
              {"last_error_at", l.error_at.empty() ? json(nullptr) : json(l.error_at)},
              {"next_retry_s", next},
              {"failed_attempts", l.failures},
              {"reconnects", l.reconnects}};
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
    if (fault_latched_) {
      detail = fault_reason_;
    } else if (!motion_ || !photometer_) {
      state = "unavailable";
      detail = link(motion_ ? Side::photometer : Side::motion).error;
    } else if (!unhomed_.empty() && detail.empty()) {
      detail = "the motion controller reconnected: home every axis before moving";
    }
  }
  set_state(std::move(state), std::move(detail));
}

void Instrument::publish_state() { hub_.publish(Topic::state, "instrument.state", status()); }

AxisPositions Instrument::positions() const {
  std::lock_guard lock(mu_);
  return positions_;
}

json Instrument::positions_json() const {
  json p = json::object();
  for (const auto& [axis, deg] : positions_) p[std::string(to_text(axis))] = deg;
  return p;
}

json Instrument::status() const {
  std::lock_guard lock(mu_);
  json axes = json::array();
  for (Axis a : axes_) axes.push_back(to_text(a));
  return json{
      {"state", state_},
      {"detail", state_detail_},
      {"scan", running_ ? json(*running_) : json(nullptr)},
      {"fault_latched", fault_latched_},
      {"fault_reason", fault_reason_},
      {"available", motion_ != nullptr && photometer_ != nullptr},
      {"error", !link(Side::motion).up ? link(Side::motion).error
                : !link(Side::photometer).up ? link(Side::photometer).error : std::string()},
      {"devices", {{"motion", link_json(Side::motion)}, {"photometer", link_json(Side::photometer)}}},
      {"axes_to_home", [&] {
         json a = json::array();
         for (Axis x : unhomed_) a.push_back(to_text(x));
         return a;
       }()},
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
      {"profile", twin_.profile_info()},
      {"storage", storage_.to_json()},
  };
}

std::string Instrument::stats_text() const {
  std::lock_guard lock(mu_);
  // system.info is polled far more often than points are measured.
  if (stats_cache_ && stats_cache_->first == points_measured_) return stats_cache_->second;
  std::vector<double> v(overhead_ms_.begin(), overhead_ms_.end());
  std::sort(v.begin(), v.end());
  const auto q = [&](double f) -> std::optional<double> {
    if (v.empty()) return std::nullopt;
    return v[std::min(v.size() - 1, static_cast<std::size_t>(f * static_cast<double>(v.size())))];
  };
  std::string out;
  JsonWriter(out)
      .begin_object()
      .member("points_measured", points_measured_)
      .member("overhead_ms_p50", q(0.5))
      .member("overhead_ms_p99", q(0.99))
      .member("overhead_ms_max", v.empty() ? std::nullopt : std::optional<double>(v.back()))
      .member("overhead_window", v.size())
      .end_object();
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
  rpc::mark_measurement_thread();  // the runner comes before client work (rpc/governor.hpp)
  for (;;) {
    beat();
    std::unique_lock lock(mu_);
    if (stopping_) break;
    if (!commands_.empty()) {
      auto cmd = commands_.front();
      commands_.pop_front();
      // An earlier command may have lost a device since this one was accepted.
      if (cmd->needs_devices && (!motion_ || !photometer_)) {
        cmd->done.set_exception(std::make_exception_ptr(devices_down()));
        continue;
      }
      lock.unlock();
      try {
        cmd->done.set_value(cmd->fn());
      } catch (...) {
        cmd->done.set_exception(std::current_exception());
      }
      continue;
    }
    if (!motion_ || !photometer_) {
      // No run is in progress: a device is dropped only after its fault paused the run.
      std::optional<Clock::time_point> due;
      for (const Side s : {Side::motion, Side::photometer})
        if (const auto& l = link(s); !l.up && l.next_retry)
          due = due ? std::min(*due, *l.next_retry) : *l.next_retry;
      const auto at = due.value_or(Clock::now());
      if (Clock::now() >= at) {
        lock.unlock();
        try {
          open_devices();
        } catch (const std::exception& e) {
          spdlog::error("instrument: {}", e.what());
        }
        continue;
      }
      cv_.wait_until(lock, at);
      continue;
    }
    if (run_) {
      lock.unlock();
      run_turn();
      continue;
    }
    auto wait_until = Clock::now() + std::chrono::seconds(1);
    if (auto_resume_) wait_until = std::min(wait_until, auto_resume_->second);
    lock.unlock();
    if (start_next()) continue;
    lock.lock();
    if (stopping_ || !commands_.empty()) continue;
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
    finish_run(ScanState::interrupted,
               fmt::format("goniod stopped; resumes at point {} of {}", run_->next(), run_->scan().points_total),
               "goniod");
  }
  std::deque<std::shared_ptr<Command>> pending;
  {
    std::lock_guard lock(mu_);
    pending.swap(commands_);
  }
  for (auto& c : pending)
    c->done.set_exception(std::make_exception_ptr(Error::wrong_state("", "goniod is stopping")));
}

void Instrument::run_turn() {
  {
    std::unique_lock lock(mu_);
    if (control_ != Control::none) {
      const auto c = control_;
      const auto reason = control_reason_, actor = control_actor_;
      control_ = Control::none;
      lock.unlock();
      std::lock_guard sched(sched_mu_);
      finish_run(c == Control::pause ? ScanState::paused : ScanState::cancelled, reason, actor);
      return;
    }
  }
  check_storage();
  try {
    step();
  } catch (const std::exception& e) {
    // Not a fault of the devices or the store (those are PointFaults): a defect. The scan
    // fails rather than the daemon.
    const auto id = run_ ? run_->id() : 0;
    spdlog::error("scan {}: internal error: {}", id, e.what());
    alerts_.raise(AlertDraft{.kind = std::string(alert_kind::scan_failed),
                             .severity = Severity::critical,
                             .dedup_key = fmt::format("scan_failed:scan:{}", id),
                             .scan_id = id,
                             .message = fmt::format("scan {} failed: {}", id, e.what())});
    std::lock_guard sched(sched_mu_);
    finish_run(ScanState::failed, fmt::format("internal error: {}", e.what()), "goniod");
  }
}

bool Instrument::start_next() {
  std::optional<std::int64_t> resume_id;
  {
    std::lock_guard lock(mu_);
    if (auto_resume_ && Clock::now() >= auto_resume_->second) {
      resume_id = auto_resume_->first;
      auto_resume_.reset();
    }
  }
  if (resume_id) {
    try {
      resume(*resume_id, "goniod (auto-resume)");
      spdlog::info("scan {}: resumed automatically after a device fault", *resume_id);
    } catch (const Error& e) {
      spdlog::warn("scan {}: auto-resume failed: {}", *resume_id, e.what());
    }
    return true;
  }
  check_storage();
  {
    std::lock_guard lock(mu_);
    if (stopping_ || !commands_.empty()) return true;
    // No scan starts on a store that cannot write or is low on space.
    if (fault_latched_ || !unhomed_.empty() || !store_.writable() || storage_.low_space()) return false;
  }
  std::lock_guard sched(sched_mu_);
  std::optional<Scan> next;
  try {
    next = store_.next_runnable(utc::now());
    if (next) start_run(*next);
  } catch (const Error& e) {
    spdlog::error("scheduler: {}", e.what());
  }
  return next.has_value();
}

}  // namespace gonio::daemon
