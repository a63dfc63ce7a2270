// ModbusMotion: the MotionController for Modbus motion controllers (Oriental Motor AZ
// direct data operation and compatible maps).
//
// Soft limits and the arm collision guard are not checked here: GuardedMotion
// (motion/guarded_motion.hpp) does that before a move reaches this driver. A move:
//   1. the target in device steps (out_of_range when beyond the int32 position range);
//   2. one status read: an alarm present -> device_alarm, not READY -> busy;
//   3. the direct data (operation type absolute, position, speed, rates, current) written
//      as one 16-register block ending with the trigger, which starts the motion;
//   4. polling of output status, alarm, command and feedback positions until the command
//      position equals the target, MOVE and BUSY are off and IN-POS is on with the
//      feedback within in_position_deg of the target. A feedback further than
//      following_error_deg from the command position — during the motion, or still after
//      settle_timeout once the profile ended — is a following error (the motor stalled or
//      was pushed): the axis is stopped and device_alarm thrown.
// The command position, not a stale IN-POS, decides that the new motion has finished, so
// a poll that lands before the device has taken the trigger cannot end the wait early.
//
// stop() latches a stop request (a generation counter) before it takes any link, so a
// waiting move() sees it at its next poll; a move checks the counter while holding the
// link, right before its trigger goes out, so no motion starts after a stop.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <map>
#include <optional>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "gonio/drivers/modbus/modbus_motion.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::drivers {
namespace {

using modbus::AxisConfig;
using modbus::Clock;
using modbus::ModbusLink;
using modbus::RegisterMap;

struct Raw {
  modbus::StatusBits flags;
  std::uint32_t alarm = 0;
  std::int32_t feedback = 0;
  std::int32_t command = 0;
};

std::uint16_t mask(int b) { return modbus::input_word(b); }

class ModbusMotion final : public MotionController {
 public:
  explicit ModbusMotion(const modbus::MotionConfig& cfg)
      : cfg_(cfg) {
    for (const auto& l : cfg_.links)
      links_.emplace(l.name, std::make_unique<ModbusLink>(l, cfg_.timing));
    for (const auto& a : cfg_.axes) {
      auto& st = state_[static_cast<std::size_t>(a.axis)];
      st.cfg = &a;
      st.link = links_.at(a.link).get();
    }
  }

  MotionCapabilities capabilities() const override { return {}; }

  std::vector<Axis> axes() const override {
    std::vector<Axis> out;
    for (const auto& a : cfg_.axes) out.push_back(a.axis);
    return out;
  }

  void move(Axis axis, double target_deg, milliseconds timeout) override {
    const auto deadline = Clock::now() + timeout;
    auto& st = axis_state(axis);
    const AxisConfig& a = *st.cfg;
    const std::string name(to_text(axis));
    if (!std::isfinite(target_deg))
      throw Error(Errc::limit_violation,
                  fmt::format("{}: target {} is not a finite angle", name, target_deg), name);
    const std::int32_t target = a.scale.to_steps(target_deg, name);

    const auto generation = stop_generation_.load();
    check_ready(st, name, poll(st, deadline));

    const RegisterMap& m = a.map;
    const auto enc = [&](double v) {
      const double r = std::clamp(std::round(v), 1.0, 2147483647.0);
      return modbus::encode_i32(static_cast<std::int32_t>(r), m.word_order);
    };
    const auto speed = enc(a.scale.to_step_rate(a.speed_deg_s));
    const auto rate = enc(a.scale.to_step_rate(a.accel_deg_s2) / m.rate_unit_hz_per_s);
    const auto stop_rate = enc(a.scale.to_step_rate(a.decel_deg_s2) / m.rate_unit_hz_per_s);
    const auto current = modbus::encode_i32(
        static_cast<std::int32_t>(std::round(a.current_percent / m.current_unit_percent)),
        m.word_order);
    const auto pos = modbus::encode_i32(target, m.word_order);
    const auto op = modbus::encode_i32(m.operation_type_absolute, m.word_order);
    const auto zero = modbus::encode_i32(0, m.word_order);
    const auto trig = modbus::encode_i32(m.trigger_value, m.word_order);
    const auto not_stopped = [&] {
      if (stop_generation_.load() != generation)
        throw Error(Errc::invalid_state,
                    fmt::format("{}: move to {:g}° cancelled by stop before it started", name,
                                target_deg),
                    name);
    };

    spdlog::debug("modbus {}: move to {:g}° ({} steps)", name, target_deg, target);
    if (m.direct_block()) {
      // data no., operation type, position, speed, rate, stop rate, current, trigger.
      std::array<std::uint16_t, 16> block{};
      const std::array<std::array<std::uint16_t, 2>, 8> values{zero, op, pos, speed,
                                                                rate, stop_rate, current, trig};
      for (std::size_t i = 0; i < values.size(); ++i) {
        block[2 * i] = values[i][0];
        block[2 * i + 1] = values[i][1];
      }
      st.link->write(a.unit, m.data_no, block, deadline, not_stopped);
    } else {
      const std::array<std::pair<std::uint16_t, std::array<std::uint16_t, 2>>, 7> fields{{
          {m.data_no, zero}, {m.operation_type, op}, {m.position, pos}, {m.speed, speed},
          {m.rate, rate}, {m.stop_rate, stop_rate}, {m.current, current}}};
      for (const auto& [addr, v] : fields) st.link->write(a.unit, addr, v, deadline);
      st.link->write(a.unit, m.trigger, trig, deadline, not_stopped);
    }

    wait_in_position(st, name, fmt::format("move to {:g}°", target_deg), target, generation,
                     deadline, /*homing=*/false);
  }

  double position(Axis axis, milliseconds timeout) override {
    auto& st = axis_state(axis);
    const auto& m = st.cfg->map;
    const auto r = st.link->read(st.cfg->unit, m.feedback_position, 2, Clock::now() + timeout);
    const double deg = st.cfg->scale.to_degrees(modbus::decode_i32(r[0], r[1], m.word_order));
    return deg;
  }

  AxisStatus status(Axis axis, milliseconds timeout) override {
    auto& st = axis_state(axis);
    const Raw raw = poll(st, Clock::now() + timeout);
    return to_status(st, raw);
  }

  // Homing ends at device position 0 (the motion guard checks the path there).
  std::optional<double> home_position(Axis axis) const override {
    const auto& st = state_[static_cast<std::size_t>(axis)];
    if (!st.cfg) return std::nullopt;
    return st.cfg->scale.to_degrees(0);
  }

  void home(Axis axis, milliseconds timeout) override {
    const auto deadline = Clock::now() + timeout;
    auto& st = axis_state(axis);
    const std::string name(to_text(axis));
    const auto generation = stop_generation_.load();
    check_ready(st, name, poll(st, deadline));
    const auto& m = st.cfg->map;
    const bool started = pulse_input(st, name, m.input.zhome, deadline, generation, [&](const Raw& r) {
      return r.flags.busy || r.flags.moving || r.flags.home_end;
    });
    if (!started)
      throw Error(Errc::protocol_error,
                  fmt::format("{}: unit {} did not react to ZHOME (input bit {})", name,
                              st.cfg->unit, m.input.zhome),
                  name);
    wait_in_position(st, name, "homing", std::nullopt, generation, deadline, /*homing=*/true);
  }

  void reset_alarm(Axis axis, milliseconds timeout) override {
    const auto deadline = Clock::now() + timeout;
    auto& st = axis_state(axis);
    const std::string name(to_text(axis));
    const auto& m = st.cfg->map;
    // ALM-RST acts on its rising edge; hold it until the alarm clears (or briefly).
    pulse_input(st, name, m.input.alarm_reset, deadline, std::nullopt,
                [](const Raw& r) { return !r.flags.alarm; });
    const Raw r = poll(st, deadline);
    if (r.flags.alarm)
      throw Error(Errc::device_alarm,
                  fmt::format("{}: alarm 0x{:02X} persists after reset (unit {})", name, r.alarm,
                              st.cfg->unit),
                  name);
  }

  void stop(milliseconds timeout) override {
    const auto deadline = Clock::now() + timeout;
    stop_generation_.fetch_add(1);
    std::optional<Error> first_error;
    const auto attempt = [&](auto&& fn) {
      try {
        fn();
      } catch (const Error& e) {
        if (!first_error) first_error = e;
      }
    };
    // STOP on everywhere first, then wait for standstill, then STOP off (it is a level
    // input: while it is on, the device refuses to start).
    for (auto& st : state_)
      if (st.cfg)
        attempt([&] {
          st.link->write(st.cfg->unit, st.cfg->map.input_command,
                         std::array{mask(st.cfg->map.input.stop)}, deadline);
        });
    for (auto& st : state_)
      if (st.cfg)
        attempt([&] {
          while (true) {
            const Raw r = poll(st, deadline);
            if (!r.flags.moving) break;
            if (Clock::now() + cfg_.poll_interval >= deadline) break;
            std::this_thread::sleep_for(cfg_.poll_interval);
          }
        });
    for (auto& st : state_)
      if (st.cfg) {
        attempt([&] {
          st.link->write(st.cfg->unit, st.cfg->map.input_command, std::array<std::uint16_t, 1>{0},
                         std::max(deadline, Clock::now() + cfg_.timing.response_timeout));
        });
      }
    if (first_error) throw Error(first_error->code(), fmt::format("stop: {}", first_error->what()), first_error->field());
  }

 private:
  struct AxisState {
    const AxisConfig* cfg = nullptr;
    ModbusLink* link = nullptr;
  };

  AxisState& axis_state(Axis axis) {
    auto& st = state_[static_cast<std::size_t>(axis)];
    if (!st.cfg)
      throw Error(Errc::unsupported,
                  fmt::format("{}: this Modbus controller has no such axis", to_text(axis)),
                  std::string(to_text(axis)));
    return st;
  }

  // Output status, alarm code, feedback and command positions, in as few reads as the
  // map's layout allows (contiguous registers are read together).
  Raw poll(AxisState& st, Clock::time_point deadline) {
    const auto& m = st.cfg->map;
    struct Want {
      std::uint16_t addr;
      int count;
      std::uint16_t* dst;
    };
    std::array<std::uint16_t, 7> regs{};
    std::array<Want, 4> wants{{{m.output_status, 1, &regs[0]},
                               {m.alarm_code, 2, &regs[1]},
                               {m.feedback_position, 2, &regs[3]},
                               {m.command_position, 2, &regs[5]}}};
    std::sort(wants.begin(), wants.end(), [](const Want& a, const Want& b) { return a.addr < b.addr; });
    std::size_t i = 0;
    while (i < wants.size()) {
      std::size_t j = i + 1;
      int count = wants[i].count;
      while (j < wants.size() && wants[j].addr == wants[i].addr + count) count += wants[j++].count;
      const auto r = st.link->read(st.cfg->unit, wants[i].addr, count, deadline);
      for (std::size_t k = i; k < j; ++k)
        std::copy_n(r.begin() + (wants[k].addr - wants[i].addr), wants[k].count, wants[k].dst);
      i = j;
    }
    Raw raw;
    raw.flags = modbus::decode_status(regs[0], m.output);
    raw.alarm = modbus::decode_u32(regs[1], regs[2], m.word_order);
    raw.feedback = modbus::decode_i32(regs[3], regs[4], m.word_order);
    raw.command = modbus::decode_i32(regs[5], regs[6], m.word_order);
    return raw;
  }

  AxisStatus to_status(AxisState& st, const Raw& r) {
    AxisStatus s;
    s.ready = r.flags.ready;
    s.busy = r.flags.busy;
    s.moving = r.flags.moving;
    s.in_position = r.flags.in_position;
    s.alarm = r.flags.alarm;
    s.alarm_code = r.alarm;
    s.home_end = r.flags.home_end;
    s.position_deg = st.cfg->scale.to_degrees(r.feedback);
    s.command_deg = st.cfg->scale.to_degrees(r.command);
    return s;
  }

  void check_ready(AxisState& st, const std::string& name, const Raw& r) {
    if (r.flags.alarm)
      throw Error(Errc::device_alarm,
                  fmt::format("{}: alarm 0x{:02X} present on unit {}; reset it first", name,
                              r.alarm, st.cfg->unit),
                  name);
    if (!r.flags.ready)
      throw Error(Errc::busy,
                  fmt::format("{}: unit {} is not ready ({})", name, st.cfg->unit,
                              r.flags.moving ? "moving" : "stopped, de-energised or busy"),
                  name);
  }

  // Sets one input bit, holds it until `acknowledged` (or 200 ms), then clears it: inputs
  // such as ZHOME and ALM-RST act on their rising edge and must be seen by the device.
  template <typename Ack>
  bool pulse_input(AxisState& st, const std::string& name, int input_bit, Clock::time_point deadline,
                   std::optional<std::uint64_t> generation, Ack acknowledged) {
    const auto& m = st.cfg->map;
    const auto guard = [&] {
      if (generation && stop_generation_.load() != *generation)
        throw Error(Errc::invalid_state, fmt::format("{}: cancelled by stop", name), name);
    };
    st.link->write(st.cfg->unit, m.input_command, std::array{mask(input_bit)}, deadline, guard);
    const auto hold_until = std::min(deadline, Clock::now() + std::chrono::milliseconds(200));
    std::optional<Error> failure;
    bool acked = false;
    try {
      while (true) {
        if ((acked = acknowledged(poll(st, deadline)))) break;
        if (Clock::now() + cfg_.poll_interval >= hold_until) break;
        std::this_thread::sleep_for(cfg_.poll_interval);
      }
    } catch (const Error& e) {
      failure = e;
    }
    st.link->write(st.cfg->unit, m.input_command, std::array<std::uint16_t, 1>{0},
                   std::max(deadline, Clock::now() + cfg_.timing.response_timeout));
    if (failure) throw *failure;
    return acked;
  }

  void stop_quietly(AxisState& st) {
    try {
      const auto d = Clock::now() + cfg_.timing.response_timeout * 2;
      st.link->write(st.cfg->unit, st.cfg->map.input_command, std::array{mask(st.cfg->map.input.stop)}, d);
      st.link->write(st.cfg->unit, st.cfg->map.input_command, std::array<std::uint16_t, 1>{0}, d);
    } catch (const Error& e) {
      spdlog::warn("modbus {}: could not stop after a failed move: {}", to_text(st.cfg->axis), e.what());
    }
  }

  void wait_in_position(AxisState& st, const std::string& name, const std::string& what,
                        std::optional<std::int32_t> target, std::uint64_t generation,
                        Clock::time_point deadline, bool homing) {
    const AxisConfig& a = *st.cfg;
    const auto& o = a.map.output;
    const double spd = std::abs(a.scale.steps_per_degree);
    const double band_steps = a.in_position_deg * spd + 0.5;
    const double following_steps = a.following_error_deg * spd + 0.5;
    // Clock::time_point::max() while the condition does not hold.
    constexpr auto never = Clock::time_point::max();
    auto profile_done_at = never;
    auto idle_since = never;
    Raw r;
    while (true) {
      if (stop_generation_.load() != generation)
        throw Error(Errc::invalid_state, fmt::format("{}: {} interrupted by stop", name, what), name);
      try {
        r = poll(st, deadline);
      } catch (const Error& e) {
        if (e.code() == Errc::timeout) stop_quietly(st);
        throw;
      }
      if (stop_generation_.load() != generation)
        throw Error(Errc::invalid_state,
                    fmt::format("{}: {} interrupted by stop at {:g}°", name, what,
                                a.scale.to_degrees(r.feedback)),
                    name);
      if (r.flags.alarm)
        throw Error(Errc::device_alarm,
                    fmt::format("{}: alarm 0x{:02X} during {} (unit {}, at {:g}°)", name, r.alarm,
                                what, a.unit, a.scale.to_degrees(r.feedback)),
                    name);
      const bool moving = r.flags.moving || r.flags.busy;
      const double lag = std::abs(static_cast<double>(r.feedback) - static_cast<double>(r.command));
      if (moving && lag > following_steps) {
        stop_quietly(st);
        throw following_error(st, name, what, r);
      }
      const bool profile_done =
          !moving && (homing ? (o.home_end < 0 || r.flags.home_end) : r.command == *target);
      if (profile_done) {
        const double miss = target ? std::abs(static_cast<double>(r.feedback) - *target) : lag;
        if (r.flags.in_position && miss <= band_steps && lag <= band_steps) break;
        if (profile_done_at == never) profile_done_at = Clock::now();
        if (Clock::now() - profile_done_at >= cfg_.settle_timeout) {
          if (lag > following_steps || miss > band_steps) throw following_error(st, name, what, r);
          throw Error(Errc::protocol_error,
                      fmt::format("{}: {} ended at {:g}° but the device never reported "
                                  "IN-POS",
                                  name, what, a.scale.to_degrees(r.feedback)),
                      name);
        }
      } else {
        profile_done_at = never;
        // Neither moving nor at the target: the device has not taken the command.
        if (moving) idle_since = never;
        else if (idle_since == never) idle_since = Clock::now();
        else if (Clock::now() - idle_since >= cfg_.settle_timeout)
          throw Error(Errc::protocol_error,
                      fmt::format("{}: unit {} did not start the {} (command position stays at "
                                  "{:g}°)",
                                  name, a.unit, what, a.scale.to_degrees(r.command)),
                      name);
      }
      if (Clock::now() + cfg_.poll_interval >= deadline) {
        stop_quietly(st);
        throw Error(Errc::timeout,
                    fmt::format("{}: {} did not finish in time (at {:g}°, command {:g}°); "
                                "axis stopped",
                                name, what, a.scale.to_degrees(r.feedback),
                                a.scale.to_degrees(r.command)),
                    name);
      }
      std::this_thread::sleep_for(cfg_.poll_interval);
    }
  }

  Error following_error(AxisState& st, const std::string& name, const std::string& what,
                        const Raw& r) {
    const AxisConfig& a = *st.cfg;
    return Error(Errc::device_alarm,
                 fmt::format("{}: following error during {}: feedback {:g}° vs command {:g}° "
                             "({} steps apart, limit {:g}°; no device alarm code)",
                             name, what, a.scale.to_degrees(r.feedback),
                             a.scale.to_degrees(r.command),
                             std::abs(static_cast<long long>(r.feedback) - r.command),
                             a.following_error_deg),
                 name);
  }

  modbus::MotionConfig cfg_;
  std::map<std::string, std::unique_ptr<ModbusLink>> links_;
  std::array<AxisState, kAllAxes.size()> state_{};
  std::atomic<std::uint64_t> stop_generation_{0};
};

}  // namespace

std::unique_ptr<MotionController> make_modbus_motion(const modbus::MotionConfig& config) {
  return std::make_unique<ModbusMotion>(config);
}

std::unique_ptr<MotionController> make_modbus_motion(const nlohmann::json& config) {
  return make_modbus_motion(modbus::MotionConfig::from_json(config));
}

}  // namespace gonio::drivers
