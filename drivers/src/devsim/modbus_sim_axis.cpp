// SimAxis: the motion model of one simulated AZ axis — trapezoidal profile integrated in
// 1 ms steps, deceleration stop, homing, scripted alarm and stall (see modbus_sim.hpp).
#include <algorithm>
#include <cmath>
#include <utility>

#include "gonio/sim/devsim/modbus_sim.hpp"

namespace gonio::drivers::devsim {
namespace {
constexpr double kStep = 1e-3;  // s

double sign(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0); }
bool passed(double pos, double point, double dir) { return (pos - point) * dir >= 0; }
}  // namespace

SimAxis::SimAxis(SimAxisConfig config, bool instant)
    : cfg_(std::move(config)), instant_(instant), cmd_(cfg_.position_steps) {}

std::int32_t SimAxis::command() const noexcept { return static_cast<std::int32_t>(std::lround(cmd_)); }

std::int32_t SimAxis::feedback() const noexcept {
  return static_cast<std::int32_t>(std::lround(frozen_fb_.value_or(cmd_)));
}

bool SimAxis::in_position() const noexcept {
  return !moving() && std::abs(feedback() - static_cast<double>(command())) <= cfg_.in_position_band_steps;
}

bool SimAxis::ready() const noexcept { return alarm_ == 0 && !moving() && !stop_ && !free_; }

void SimAxis::begin(double target, double speed, double accel, double decel, Mode mode) {
  // A new operation starts from where the motor really is.
  if (frozen_fb_) cmd_ = *frozen_fb_;
  frozen_fb_.reset();
  stall_at_.reset();
  alarm_at_.reset();
  home_end_ = false;
  start_ = cmd_;
  target_ = target;
  vmax_ = speed;
  acc_ = accel;
  dec_ = decel;
  v_ = 0;
  mode_ = mode;
  if (mode == Mode::positioning) {
    ++moves_;
    const auto at = [&](const SimFault& f) { return start_ + f.fraction * (target_ - start_); };
    if (cfg_.stall_at_move && cfg_.stall_at_move->move == moves_) stall_at_ = at(*cfg_.stall_at_move);
    if (cfg_.alarm_at_move && cfg_.alarm_at_move->move == moves_) {
      alarm_at_ = at(*cfg_.alarm_at_move);
      pending_alarm_ = cfg_.alarm_at_move->code;
    }
  }
  if (instant_) {
    // Jump to the end, honouring the scripted faults on the way.
    if (alarm_at_) {
      cmd_ = *alarm_at_;
      raise_alarm(pending_alarm_);
      return;
    }
    if (stall_at_) frozen_fb_ = *stall_at_;
    cmd_ = target_;
    finish();
    return;
  }
  step(0);
}

void SimAxis::start_move(std::int32_t target, double speed_hz, double accel_hz_s,
                         double decel_hz_s) {
  if (!ready()) return;
  if (!(speed_hz > 0) || !(accel_hz_s > 0) || !(decel_hz_s > 0)) {
    raise_alarm(kOperationDataError);
    return;
  }
  begin(target, speed_hz, accel_hz_s, decel_hz_s, Mode::positioning);
}

void SimAxis::start_home() {
  if (!ready()) return;
  begin(cfg_.home_position_steps, cfg_.home_speed_hz, cfg_.home_accel_hz_s, cfg_.home_accel_hz_s,
        Mode::homing);
}

void SimAxis::set_stop(bool on) {
  stop_ = on;
  if (on && (mode_ == Mode::positioning || mode_ == Mode::homing)) {
    mode_ = Mode::stopping;
    if (instant_ || v_ == 0) finish();
  }
}

void SimAxis::set_free(bool on) {
  free_ = on;
  if (on && moving()) {
    v_ = 0;
    finish();
  }
}

void SimAxis::reset_alarm() {
  if (alarm_ == 0) return;
  alarm_ = 0;
  // The AZ sets the command position to the feedback position on alarm reset.
  if (frozen_fb_) cmd_ = *frozen_fb_;
  frozen_fb_.reset();
  cmd_ = std::round(cmd_);
}

void SimAxis::raise_alarm(std::uint32_t code) {
  alarm_ = code == 0 ? 1 : code;
  v_ = 0;
  mode_ = Mode::idle;
  alarm_at_.reset();
  cmd_ = std::round(cmd_);
}

void SimAxis::finish() {
  const bool homing = mode_ == Mode::homing;
  mode_ = Mode::idle;
  v_ = 0;
  cmd_ = std::round(cmd_);
  if (homing) home_end_ = true;
}

void SimAxis::advance(double seconds) {
  while (seconds > 0 && moving()) {
    const double h = std::min(seconds, kStep);
    step(h);
    seconds -= h;
  }
}

void SimAxis::step(double h) {
  if (mode_ == Mode::idle) return;
  const double dir = sign(target_ - start_);
  if (mode_ == Mode::stopping) {
    const double dv = dec_ * h;
    if (std::abs(v_) <= dv) {
      finish();
      return;
    }
    v_ -= sign(v_) * dv;
    cmd_ += v_ * h;
  } else {
    const double d = target_ - cmd_;
    if (std::abs(d) < 0.5 && std::abs(v_) <= dec_ * std::max(h, kStep)) {
      cmd_ = target_;
      finish();
      return;
    }
    // Fastest speed from which the remaining distance can still be stopped in.
    const double vdes = sign(d) * std::min(vmax_, std::sqrt(2 * dec_ * std::abs(d)));
    if (v_ < vdes) v_ = std::min(vdes, v_ + (v_ >= 0 ? acc_ : dec_) * h);
    else v_ = std::max(vdes, v_ - (v_ <= 0 ? acc_ : dec_) * h);
    const double next = cmd_ + v_ * h;
    if ((target_ - next) * sign(d) <= 0) {
      cmd_ = target_;
    } else {
      cmd_ = next;
    }
  }
  if (stall_at_ && !frozen_fb_ && passed(cmd_, *stall_at_, dir)) frozen_fb_ = *stall_at_;
  if (alarm_at_ && passed(cmd_, *alarm_at_, dir)) {
    raise_alarm(pending_alarm_);
    return;
  }
  if (mode_ != Mode::stopping && cmd_ == target_) finish();
}

}  // namespace gonio::drivers::devsim
