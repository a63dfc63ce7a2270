// RegisterMap — where a Modbus motion controller keeps its commands and its status, and
// how values are encoded in 16-bit holding registers.
//
// The built-in preset `az` is the Oriental Motor AZ series "direct data operation" map
// (AZ series function edition, Modbus RTU chapter: direct data operation, driver input
// command, driver output status, monitor commands):
//   0x0058 data no.      0x005A operation type  0x005C position   0x005E speed
//   0x0060 change rate   0x0062 stop rate       0x0064 current    0x0066 trigger
//   (each a 32-bit pair; the eight may be written as one 16-register block ending with
//   trigger = 1, which starts the operation)
//   0x007D driver input command, lower word: START 3, ZHOME 4, STOP 5, FREE 6, ALM-RST 7
//   0x007F driver output status, lower word: HOME-END 4, READY 5, ALM-A 7, SYS-BSY 8,
//          MOVE 13, IN-POS 14
//   0x0080 present alarm (32-bit), 0x0120 feedback position, 0x0122 command position
// 32-bit values occupy two registers, upper word at the lower address (AZ default; the
// order is configurable for other devices). Units (AZ): position in steps, speed in Hz
// (steps/s), rates in 0.001 kHz/s (= 1 Hz/s), operating current in 0.1 %.
//
// A map is read from JSON: {"preset": "az", "registers": {...}, "input_bits": {...},
// "output_bits": {...}, ...} — every key optional and overriding the preset; addresses are
// integers or "0x..." strings; unknown keys, overlapping registers and duplicate bits are
// rejected with the field named.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace gonio::drivers::modbus {

enum class WordOrder { high_first, low_first };

struct RegisterMap {
  // Direct data operation (32-bit values).
  std::uint16_t data_no = 0x0058;
  std::uint16_t operation_type = 0x005A;
  std::uint16_t position = 0x005C;
  std::uint16_t speed = 0x005E;
  std::uint16_t rate = 0x0060;
  std::uint16_t stop_rate = 0x0062;
  std::uint16_t current = 0x0064;
  std::uint16_t trigger = 0x0066;
  // Remote I/O (single 16-bit registers).
  std::uint16_t input_command = 0x007D;
  std::uint16_t output_status = 0x007F;
  // Monitors (32-bit values).
  std::uint16_t alarm_code = 0x0080;
  std::uint16_t feedback_position = 0x0120;
  std::uint16_t command_position = 0x0122;

  struct InputBits {
    int start = 3, zhome = 4, stop = 5, free = 6, alarm_reset = 7;
    friend bool operator==(const InputBits&, const InputBits&) = default;
  } input;
  struct OutputBits {
    int home_end = 4;  // -1: the device has no home-end signal
    int ready = 5, alarm = 7, busy = 8, move = 13, in_position = 14;
    friend bool operator==(const OutputBits&, const OutputBits&) = default;
  } output;

  WordOrder word_order = WordOrder::high_first;
  std::int32_t operation_type_absolute = 1;  // AZ: 1 = absolute positioning
  std::int32_t trigger_value = 1;            // AZ: 1 = reflect all data and start
  double rate_unit_hz_per_s = 1.0;           // acceleration of one rate count
  double current_unit_percent = 0.1;         // current of one count

  friend bool operator==(const RegisterMap&, const RegisterMap&) = default;

  // Throws Error(not_found) listing the known presets.
  static RegisterMap preset(std::string_view name);
  // Strict reading; `context` prefixes every error field ("axes.receive.register_map").
  static RegisterMap from_json(const nlohmann::json& j, const std::string& context);
  nlohmann::json to_json() const;

  // True when the eight direct-data values are consecutive 32-bit pairs from data_no to
  // trigger, so that one write of 16 registers sets them all and starts the operation.
  bool direct_block() const;
  // Throws Error(invalid_argument) naming `context` for overlapping registers or bits.
  void validate(const std::string& context) const;
};

// --- status word -------------------------------------------------------------------------

// The signals of the driver output status word, as named by the map's output bits.
struct StatusBits {
  bool ready = false;
  bool alarm = false;
  bool busy = false;
  bool moving = false;
  bool in_position = false;
  bool home_end = false;  // always false when the map has no home-end bit
  friend bool operator==(const StatusBits&, const StatusBits&) = default;
};

StatusBits decode_status(std::uint16_t word, const RegisterMap::OutputBits& bits) noexcept;
std::uint16_t encode_status(const StatusBits& s, const RegisterMap::OutputBits& bits) noexcept;
// The input command word with one input on (0 for bit < 0).
std::uint16_t input_word(int bit) noexcept;

// --- value encoding --------------------------------------------------------------------

std::array<std::uint16_t, 2> encode_u32(std::uint32_t v, WordOrder order) noexcept;
std::uint32_t decode_u32(std::uint16_t first, std::uint16_t second, WordOrder order) noexcept;
// Two's complement, as the AZ stores negative positions (FFFF FC18h = −1000).
std::array<std::uint16_t, 2> encode_i32(std::int32_t v, WordOrder order) noexcept;
std::int32_t decode_i32(std::uint16_t first, std::uint16_t second, WordOrder order) noexcept;

// Degrees of an axis <-> device steps: deg = zero_deg + steps / steps_per_degree.
// A negative steps_per_degree reverses the direction.
struct AxisScale {
  double steps_per_degree = 100;
  double zero_deg = 0;

  // Nearest step; throws Error(out_of_range) naming `field` when beyond int32.
  std::int32_t to_steps(double deg, const std::string& field) const;
  double to_degrees(std::int32_t steps) const noexcept;
  // Step rate for an angular rate (always >= 0).
  double to_step_rate(double deg_per_s) const noexcept;
};

// Parses 0..65535 from an integer or a "0x..."/decimal string; throws naming `field`.
std::uint16_t parse_register_address(const nlohmann::json& j, const std::string& field);

}  // namespace gonio::drivers::modbus
