// Instrument, part 3: what other threads ask of the instrument (see instrument.hpp) —
// scheduler control (pause, resume, cancel) and the one function that changes a scan's
// state, plan checks against the devices at hand, and the manual commands (home, move,
// reset, run on the runner thread; stop, immediate from any thread).
#include <algorithm>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/instrument/instrument.hpp"
#include "gonio/daemon/instrument/plan_check.hpp"
#include "gonio/proto/error.hpp"
#include "instrument/scan_run.hpp"

namespace gonio::daemon {

using drivers::Axis;
using nlohmann::json;

namespace {

// The reason stored with a state: the one given, else who did it for the states people
// bring about.
std::string worded_reason(ScanState to, const std::string& reason, const std::string& actor) {
  if (!reason.empty()) return reason;
  switch (to) {
    case ScanState::paused: return fmt::format("paused by {}", actor);
    case ScanState::cancelled: return fmt::format("cancelled by {}", actor);
    case ScanState::queued: return fmt::format("resumed by {}", actor);
    default: return {};
  }
}

}  // namespace

// ---- scheduler operations ---------------------------------------------------------------

Scan Instrument::stored_scan(std::int64_t id) const {
  auto sc = store_.scan(id);
  if (!sc) throw Error::not_found("scan", fmt::format("scan {}", id));
  return *std::move(sc);
}

Scan Instrument::transition(std::int64_t id, ScanState to, const std::string& reason,
                            const std::string& actor) {
  store_.set_scan_state(id, to, worded_reason(to, reason, actor), actor);
  const auto sc = stored_scan(id);
  hub_.publish(Topic::state, "scan.state",
               json{{"scan", id}, {"state", to_text(sc.state)}, {"reason", sc.reason}}, id);
  if (is_final(sc.state)) resolve_unsupported_alerts(id);
  return sc;
}

// Only at the end: mid-scan the verdict firms up and may swing, and an alert resolved and
// raised again would page people twice for one scan (docs/decision-rule.md).
void Instrument::resolve_unsupported_alerts(std::int64_t scan) {
  try {
    const auto fit = store_.latest_fit(scan, FitKind::verdict);
    if (!fit || !fit->result.is_object()) return;
    const auto decision = fit->result.value("decision", std::string());
    if (decision.empty()) return;
    const auto text = sustained_resolution(decision, fit->result.value("summary", std::string()));
    if (!text) return;
    AlertFilter standing;
    standing.scan_id = scan;
    standing.resolved = false;
    standing.limit = 1000;
    for (const auto& a : store_.alerts(standing))
      if (a.kind == alert_kind::sustained) alerts_.resolve(a.id, *text);
  } catch (const Error& e) {
    spdlog::warn("scan {}: cannot resolve its sustained alert: {}", scan, e.what());
  }
}

// A pause or cancel of the scan that is running is the runner's to carry out between points:
// hand it over and wait (at most a minute) until the runner has let go of the scan. Empty
// when `id` is not the running scan.
std::optional<Scan> Instrument::control_running(std::int64_t id, Control what, const std::string& reason,
                                                const std::string& actor, std::unique_lock<std::mutex>& sched) {
  std::unique_lock lock(mu_);
  if (running_ != id) return std::nullopt;
  control_ = what;
  control_reason_ = reason;
  control_actor_ = actor;
  sched.unlock();
  cv_.notify_all();
  cv_.wait_for(lock, std::chrono::seconds(60), [&] { return running_ != id; });
  lock.unlock();
  return stored_scan(id);
}

Scan Instrument::pause(std::int64_t id, const std::string& actor, const std::string& reason) {
  std::unique_lock sched(sched_mu_);
  const auto sc = stored_scan(id);
  if (auto done = control_running(id, Control::pause, reason, actor, sched)) return *std::move(done);
  if (sc.state == ScanState::paused) return sc;
  if (sc.state != ScanState::queued && sc.state != ScanState::interrupted)
    throw Error::wrong_state("scan", fmt::format("scan {} is {}; only queued, running or "
                                                 "interrupted scans can be paused",
                                                 id, to_text(sc.state)));
  return transition(id, ScanState::paused, reason, actor);
}

Scan Instrument::resume(std::int64_t id, const std::string& actor) {
  std::lock_guard sched(sched_mu_);
  const auto sc = stored_scan(id);
  if (sc.state != ScanState::paused)
    throw Error::wrong_state(
        "scan", fmt::format("scan {} is {}; only paused scans can be resumed{}", id,
                            to_text(sc.state),
                            sc.state == ScanState::interrupted
                                ? " (interrupted ones resume by themselves)"
                                : ""));
  auto queued = transition(id, ScanState::queued, "", actor);
  {
    std::lock_guard lock(mu_);
    // A technician's resume is the acknowledgement that the instrument is fit again.
    fault_latched_ = false;
    fault_reason_.clear();
    if (auto_resume_ && auto_resume_->first == id) auto_resume_.reset();
  }
  acknowledge_faults(actor);
  cv_.notify_all();
  return queued;
}

Scan Instrument::cancel(std::int64_t id, const std::string& actor, const std::string& reason) {
  std::unique_lock sched(sched_mu_);
  const auto sc = stored_scan(id);
  if (auto done = control_running(id, Control::cancel, reason, actor, sched)) return *std::move(done);
  if (is_final(sc.state))
    throw Error::wrong_state("scan", fmt::format("scan {} is already {}", id, to_text(sc.state)));
  return transition(id, ScanState::cancelled, reason, actor);
}

DeviceFacts Instrument::device_facts() const {
  std::lock_guard lock(mu_);
  DeviceFacts f{axes_, photometer_grid_, std::nullopt};
  if (positions_.contains(Axis::incidence) && positions_.contains(Axis::receive))
    f.arms = Geometry::in_plane(positions_.at(Axis::incidence), positions_.at(Axis::receive));
  return f;
}

void Instrument::validate_plan(const ScanPlan& plan) const {
  check_plan(plan, guard_, device_facts());
}

// ---- commands --------------------------------------------------------------------------

// Under mu_.
Error Instrument::devices_down() const {
  const Side down = motion_ ? Side::photometer : Side::motion;
  return Error(Errc::disconnected,
               fmt::format("the instrument is unavailable: the {} is not connected ({}){}",
                           down == Side::motion ? "motion controller" : "photometer",
                           link(down).error,
                           link(down).next_retry ? "; goniod keeps reopening it" : ""));
}

json Instrument::submit(std::function<json()> fn, bool needs_devices) {
  auto cmd = std::make_shared<Command>();
  cmd->fn = std::move(fn);
  cmd->needs_devices = needs_devices;
  auto fut = cmd->done.get_future();
  {
    std::lock_guard lock(mu_);
    if (stopping_) throw Error::wrong_state("", "goniod is stopping");
    if (running_)
      throw Error(Errc::busy,
                  fmt::format("the instrument is running scan {}; pause it first", *running_));
    if (needs_devices && (!motion_ || !photometer_)) throw devices_down();
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
                                                      for (Axis x : axes) a.push_back(to_text(x));
                                                      return a;
                                                    }()}});
    set_state("homing");
    try {
      arms_.home(*motion_, positions(), axes);
    } catch (const Error& e) {
      if (is_link_error(e.code())) drop_device(Side::motion, e);
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
    for (const auto& [axis, deg] : targets) detail[std::string(to_text(axis))] = deg;
    store_.audit(actor, "instrument.move", "", detail);
    double i = 0, r = 0;
    {
      std::lock_guard lock(mu_);
      i = positions_.contains(Axis::incidence) ? positions_[Axis::incidence] : 0;
      r = positions_.contains(Axis::receive) ? positions_[Axis::receive] : 0;
    }
    const auto ti = targets.contains(Axis::incidence) ? targets.at(Axis::incidence) : i;
    const auto tr = targets.contains(Axis::receive) ? targets.at(Axis::receive) : r;
    {
      std::lock_guard lock(mu_);
      if (!unhomed_.empty()) {
        std::string names;
        for (Axis a : unhomed_) names += (names.empty() ? "" : ", ") + std::string(to_text(a));
        throw Error::wrong_state("instrument",
                                 fmt::format("the motion controller reconnected and may have lost "
                                             "its position: home {} first (instrument.home)",
                                             names));
      }
    }
    set_state("moving");
    try {
      if (targets.contains(Axis::incidence) || targets.contains(Axis::receive))
        arms_.move(*motion_, positions(), ti, tr, std::nullopt);
      for (const auto& [axis, deg] : targets) {
        if (axis == Axis::incidence || axis == Axis::receive) continue;
        beat();
        motion_->move(axis, deg, config_.move_timeout);
        std::lock_guard lock(mu_);
        positions_[axis] = deg;
      }
    } catch (const Error& e) {
      if (is_link_error(e.code())) drop_device(Side::motion, e);
      settle_state(e.what());
      throw;
    }
    settle_state();
    return status();
  });
}

// Also with a device down: the technician has replugged it, so every device that is down is
// tried again at once, the back-off starting over.
json Instrument::reset(const std::string& actor) {
  return submit([this, actor] {
    store_.audit(actor, "instrument.reset", "", json::object());
    std::vector<Axis> axes;
    bool have_motion = false;
    {
      std::lock_guard lock(mu_);
      axes = axes_;
      have_motion = motion_ != nullptr;
    }
    try {
      if (have_motion && motion_->capabilities().alarm_reset)
        for (Axis a : axes) {
          beat();
          motion_->reset_alarm(a, config_.move_timeout);
        }
    } catch (const Error& e) {
      if (is_link_error(e.code())) drop_device(Side::motion, e);
      throw;
    }
    {
      std::lock_guard lock(mu_);
      fault_latched_ = false;
      fault_reason_.clear();
      for (Link& l : links_)
        if (!l.up) {
          l.next_retry = std::chrono::steady_clock::now();
          l.wait = config_.reconnect_initial;
        }
    }
    acknowledge_faults(actor);
    open_devices();
    cv_.notify_all();
    return status();
  }, false);
}

json Instrument::stop(const std::string& actor) {
  std::optional<std::int64_t> scan;
  {
    std::lock_guard lock(mu_);
    if (!motion_)
      throw Error(Errc::disconnected, fmt::format("the motion controller is not connected: {}",
                                                  link(Side::motion).error));
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
