// Instrument, part 2: the run of a scan on the runner thread (see instrument.hpp) — starting
// it (a ScanRun, scan_run.hpp), one point per step with ScanRun's steps in order and the one
// fault rule for them (docs/architecture.md §6), finishing it, and the device and storage
// faults that pause it.
#include <algorithm>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/instrument/instrument.hpp"
#include "gonio/proto/error.hpp"
#include "instrument/scan_run.hpp"

namespace gonio::daemon {

using drivers::Axis;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

// The codes a device call fails with; anything else from a device is taken as an alarm.
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

}  // namespace

RunContext Instrument::run_context() {
  return RunContext{.config = config_,
                    .store = store_,
                    .twin = twin_,
                    .alerts = alerts_,
                    .hub = hub_,
                    .divergence = divergence_,
                    .guard = guard_,
                    .beat = [this] { beat(); },
                    .sustained = sustained_listener_};
}

void Instrument::start_run(const Scan& scan) {
  auto r = std::make_unique<ScanRun>(run_context(), scan, device_facts().arms);
  const auto next = r->next();
  const auto resumed = next > 0;
  const auto note = r->prediction_note();
  {
    std::lock_guard lock(mu_);
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
    std::unique_ptr<ScanRun> dropped;
    {
      std::lock_guard lock(mu_);
      dropped = std::move(run_);
      running_.reset();
    }
    throw;
  }
  spdlog::info("scan {}: {} ({} points{}){}", scan.id, resumed ? "resumed" : "started",
               scan.points_total, resumed ? fmt::format(", from point {}", next) : "",
               note.empty() ? "" : "; " + note);
  set_state("scanning", fmt::format("scan {}", scan.id));
  if (status_listener_) status_listener_(fmt::format("scan {} running", scan.id));
  // A scan whose every point is stored (crash after the last commit) completes at once; so
  // does an adaptive one whose loop has reached its target or has nothing left to choose.
  if (!run_->failure().empty()) finish_run(ScanState::failed, run_->failure(), "goniod");
  else if (run_->done()) finish_run(ScanState::completed, run_->complete(), "goniod");
}

void Instrument::finish_run(ScanState state, const std::string& reason, const std::string& actor) {
  std::unique_ptr<ScanRun> r;
  {
    std::lock_guard lock(mu_);
    r = std::move(run_);
    running_.reset();
  }
  if (!r) return;
  r->end(state, actor);
  std::optional<Scan> sc;
  try {
    sc = transition(r->id(), state, reason, actor);
    spdlog::info("scan {}: {}{}", r->id(), to_text(state), sc->reason.empty() ? "" : ": " + sc->reason);
  } catch (const Error& e) {
    spdlog::error("scan {}: cannot record state {}: {}", r->id(), to_text(state), e.what());
    if (e.code() == Errc::storage_unavailable) {
      // Published now, stored once the store can write (check_storage).
      storage_.hold(StorageWatch::UnsavedState{r->id(), state, reason, actor});
      hub_.publish(Topic::state, "scan.state",
                   json{{"scan", r->id()}, {"state", to_text(state)}, {"reason", reason}, {"stored", false}},
                   r->id());
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
  if (status_listener_) status_listener_(fmt::format("scan {} {}", r->id(), to_text(state)));
  cv_.notify_all();  // pause()/cancel() wait for this
}

// One point, as docs/architecture.md §6 tells it: its steps 3–8, ScanRun's.
void Instrument::step() {
  ScanRun& r = *run_;
  auto pt = r.begin_point();
  PointRecord& p = pt.record;
  std::optional<std::string> pause;
  try {
    PointDevices d{.motion = *motion_, .photometer = *photometer_, .arms = arms_, .ranger = ranger_,
                   .at = positions()};
    {
      std::lock_guard lock(mu_);
      d.has_rotation = std::find(axes_.begin(), axes_.end(), Axis::rotation) != axes_.end();
    }
    const auto in = r.read(pt, d);
    r.reduce(in, p);
    r.predict_and_judge(pt);
    p.finished_at = utc::now();
    const std::string text = json(p).dump();
    r.commit(p, text);
    const double total_s = std::chrono::duration<double>(Clock::now() - pt.started).count();
    {
      std::lock_guard lock(mu_);
      ++points_measured_;
      overhead_ms_.push_back(1000.0 * std::max(0.0, total_s - pt.device_s - pt.twin_s));
      if (overhead_ms_.size() > 1000) overhead_ms_.pop_front();
    }
    r.publish(text);
    pause = r.after_commit(pt);
  } catch (const PointFault& f) {
    on_point_fault(f);
    return;
  }
  after_point(pause);
}

void Instrument::after_point(const std::optional<std::string>& pause) {
  if (run_->done()) {
    std::lock_guard sched(sched_mu_);
    finish_run(ScanState::completed, run_->complete(), "goniod");
  } else if (pause) {
    std::lock_guard lock(mu_);
    control_ = Control::pause;
    control_reason_ = *pause;
    control_actor_ = "goniod";
  }
}

// The one rule for a point step that could not finish (docs/architecture.md §6): the scan
// pauses — for the store, with a storage alert; for a device, with a device fault that
// latches the instrument (a lost link also closes the device). An interrupted move while a
// pause is asked for (instrument.stop) is that pause, no fault.
void Instrument::on_point_fault(const PointFault& f) {
  if (f.party() == FaultParty::store) {
    on_storage_fault(f);
    return;
  }
  bool stop_requested = false;
  {
    std::lock_guard lock(mu_);
    stop_requested = control_ == Control::pause;
  }
  if (f.code() == Errc::invalid_state && stop_requested) return;  // the loop applies the pause
  if (is_link_error(f.code())) drop_device(f.party() == FaultParty::motion ? Side::motion : Side::photometer, f);
  if (is_device_error(f.code()) || f.code() == Errc::invalid_state) on_device_fault(f);
  else on_device_fault(Error(Errc::device_alarm, f.what()));
}

void Instrument::on_device_fault(const Error& e) {
  std::int64_t id = 0;
  {
    std::lock_guard lock(mu_);
    id = run_ ? run_->id() : 0;
    fault_latched_ = true;
    fault_reason_ = fmt::format("{} ({})", e.what(), e.id());
  }
  const auto reason = fmt::format("device fault: {} ({}); a technician must resume", e.what(), e.id());
  spdlog::error("scan {}: {}", id, reason);
  alerts_.raise(AlertDraft{.kind = std::string(alert_kind::device_fault),
                           .severity = Severity::critical,
                           .dedup_key = fmt::format("device_fault:scan:{}", id),
                           .scan_id = id,
                           .message = fmt::format("scan {} paused: {}", id, reason)});
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

void Instrument::on_storage_fault(const Error& e) {
  std::int64_t id = 0;
  {
    std::lock_guard lock(mu_);
    id = run_ ? run_->id() : 0;
  }
  const auto reason = e.code() == Errc::storage_unavailable
                          ? fmt::format("storage: {}; free space, then resume the scan", e.what())
                          : fmt::format("storage: {}; check the store, then resume the scan", e.what());
  spdlog::error("scan {}: {}", id, reason);
  // The pause and its alert may use the store's reserve; without one (a read-only file
  // system) the alert is held in memory and published, the state stored later.
  Store::Essential essential;
  alerts_.raise(AlertDraft{.kind = std::string(alert_kind::storage),
                           .severity = Severity::critical,
                           .dedup_key = "storage:unwritable",
                           .scan_id = id,
                           .message = fmt::format("scan {} paused: {}", id, reason)});
  std::lock_guard sched(sched_mu_);
  finish_run(ScanState::paused, reason, "goniod");
}

void Instrument::check_storage() {
  if (!storage_.poll()) return;
  std::lock_guard sched(sched_mu_);
  storage_.write_waiting([this](const StorageWatch::UnsavedState& u) { transition(u.scan, u.state, u.reason, u.actor); });
}

std::optional<json> Instrument::adaptive_status(std::int64_t scan) const {
  std::lock_guard lock(mu_);
  if (!run_ || run_->id() != scan) return std::nullopt;
  auto j = run_->adaptive_status();
  if (j.is_null()) return std::nullopt;
  return j;
}

}  // namespace gonio::daemon
