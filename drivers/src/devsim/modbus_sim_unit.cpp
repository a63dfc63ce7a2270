// SimUnit: the register behaviour of one simulated AZ unit — what a write of the trigger or
// the input command does to its SimAxis, and what the status and monitor registers show
// (see modbus_sim.hpp). No I/O: the server and the unit tests drive it alike.
#include <algorithm>
#include <array>
#include <utility>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/proto/error.hpp"
#include "gonio/sim/devsim/modbus_sim.hpp"

namespace gonio::drivers::devsim {
namespace {


// The image spans at least 0x200 registers and every register of the map.
std::size_t image_size(const modbus::RegisterMap& m) {
  int top = 0x200;
  for (const int a : {m.input_command, m.output_status, m.alarm_code, m.feedback_position,
                      m.command_position, m.trigger, m.data_no, m.position, m.speed, m.rate,
                      m.stop_rate, m.current, m.operation_type})
    top = std::max(top, a + 2);
  return static_cast<std::size_t>(std::min(top, 0x10000));
}

bool overlaps(int first, int count, int addr, int n) { return first < addr + n && addr < first + count; }

}  // namespace

SimUnit::SimUnit(SimAxisConfig config, modbus::RegisterMap map, bool instant)
    : map_(std::move(map)), axis_(std::move(config), instant), regs_(image_size(map_), 0) {
  refresh();
}

bool SimUnit::read_only(int first, int count) const noexcept {
  const std::array<std::pair<int, int>, 4> ro{{{map_.output_status, 1},
                                               {map_.alarm_code, 2},
                                               {map_.feedback_position, 2},
                                               {map_.command_position, 2}}};
  return std::any_of(ro.begin(), ro.end(),
                     [&](const auto& r) { return overlaps(first, count, r.first, r.second); });
}

void SimUnit::put32(std::uint16_t addr, std::uint32_t v) {
  const auto w = modbus::encode_u32(v, map_.word_order);
  regs_[addr] = w[0];
  regs_[addr + 1u] = w[1];
}

std::int32_t SimUnit::get_i32(std::uint16_t addr) const {
  return modbus::decode_i32(regs_[addr], regs_[addr + 1u], map_.word_order);
}

void SimUnit::refresh() {
  modbus::StatusBits st;
  st.ready = axis_.ready();
  st.alarm = axis_.alarm() != 0;
  st.busy = axis_.busy();
  st.moving = axis_.moving();
  st.in_position = axis_.in_position();
  st.home_end = axis_.home_end();
  regs_[map_.output_status] = modbus::encode_status(st, map_.output);
  put32(map_.alarm_code, axis_.alarm());
  put32(map_.feedback_position, static_cast<std::uint32_t>(axis_.feedback()));
  put32(map_.command_position, static_cast<std::uint32_t>(axis_.command()));
}

void SimUnit::advance(double seconds) {
  axis_.advance(seconds);
  refresh();
}

void SimUnit::raise_alarm(std::uint32_t code) {
  axis_.raise_alarm(code);
  refresh();
}

void SimUnit::start_direct() {
  if (get_i32(map_.operation_type) != map_.operation_type_absolute) {
    spdlog::warn("modbus sim unit {}: operation type {} not simulated (only absolute {})", unit(),
                 get_i32(map_.operation_type), map_.operation_type_absolute);
    axis_.raise_alarm(kOperationDataError);
    return;
  }
  axis_.start_move(get_i32(map_.position), get_i32(map_.speed),
                   get_i32(map_.rate) * map_.rate_unit_hz_per_s,
                   get_i32(map_.stop_rate) * map_.rate_unit_hz_per_s);
}

void SimUnit::written(int first, int count) {
  if (overlaps(first, count, map_.input_command, 1)) {
    // STOP and FREE are levels; ALM-RST, ZHOME and START act on their rising edge.
    const std::uint16_t now = regs_[map_.input_command];
    const auto rising = static_cast<std::uint16_t>(now & ~inputs_);
    const auto on = [&](int b) { return b >= 0 && ((now >> b) & 1u) != 0; };
    const auto rose = [&](int b) { return b >= 0 && ((rising >> b) & 1u) != 0; };
    inputs_ = now;
    axis_.set_stop(on(map_.input.stop));
    axis_.set_free(on(map_.input.free));
    if (rose(map_.input.alarm_reset)) axis_.reset_alarm();
    if (rose(map_.input.zhome)) axis_.start_home();
    if (rose(map_.input.start)) start_direct();
  }
  if (overlaps(first, count, map_.trigger, 2)) {
    // The trigger reads back 0 once taken.
    const auto t = get_i32(map_.trigger);
    put32(map_.trigger, 0);
    if (t == map_.trigger_value) start_direct();
  }
  refresh();
}

void SimUnit::check_range(int first, int count, const char* what) const {
  if (first < 0 || count < 1 || static_cast<std::size_t>(first) + static_cast<std::size_t>(count) > regs_.size())
    throw Error(Errc::out_of_range,
                fmt::format("modbus sim unit {}: {} of {} registers at 0x{:04X} is outside the "
                            "register image [0x0000, 0x{:04X}]",
                            unit(), what, count, first, regs_.size() - 1),
                "address");
}

std::vector<std::uint16_t> SimUnit::read(int first, int count) {
  check_range(first, count, "read");
  refresh();
  return {regs_.begin() + first, regs_.begin() + first + count};
}

void SimUnit::write(int first, std::span<const std::uint16_t> values) {
  const int count = static_cast<int>(values.size());
  check_range(first, count, "write");
  if (read_only(first, count))
    throw Error::invalid("address",
                         fmt::format("modbus sim unit {}: registers 0x{:04X}..0x{:04X} include a "
                                     "status or monitor register, which is read-only",
                                     unit(), first, first + count - 1));
  std::copy(values.begin(), values.end(), regs_.begin() + first);
  written(first, count);
}

}  // namespace gonio::drivers::devsim
