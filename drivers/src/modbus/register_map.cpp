// RegisterMap: presets, strict JSON reading, validation and 32-bit value encoding for
// Modbus motion controllers (see register_map.hpp for the AZ facts).
#include "gonio/drivers/modbus/register_map.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <utility>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio::drivers::modbus {
namespace {

using json_util::ObjectReader;

struct RegField {
  const char* name;
  std::uint16_t RegisterMap::*member;
  int width;  // registers
};

constexpr std::array<RegField, 13> kRegisters{{
    {"data_no", &RegisterMap::data_no, 2},
    {"operation_type", &RegisterMap::operation_type, 2},
    {"position", &RegisterMap::position, 2},
    {"speed", &RegisterMap::speed, 2},
    {"rate", &RegisterMap::rate, 2},
    {"stop_rate", &RegisterMap::stop_rate, 2},
    {"current", &RegisterMap::current, 2},
    {"trigger", &RegisterMap::trigger, 2},
    {"input_command", &RegisterMap::input_command, 1},
    {"output_status", &RegisterMap::output_status, 1},
    {"alarm_code", &RegisterMap::alarm_code, 2},
    {"feedback_position", &RegisterMap::feedback_position, 2},
    {"command_position", &RegisterMap::command_position, 2},
}};

template <typename Bits>
struct BitField {
  const char* name;
  int Bits::*member;
  int lowest;  // -1 where "absent" is allowed
};

constexpr std::array<BitField<RegisterMap::InputBits>, 5> kInputBits{{
    {"start", &RegisterMap::InputBits::start, 0},
    {"zhome", &RegisterMap::InputBits::zhome, 0},
    {"stop", &RegisterMap::InputBits::stop, 0},
    {"free", &RegisterMap::InputBits::free, 0},
    {"alarm_reset", &RegisterMap::InputBits::alarm_reset, 0},
}};

constexpr std::array<BitField<RegisterMap::OutputBits>, 6> kOutputBits{{
    {"home_end", &RegisterMap::OutputBits::home_end, -1},
    {"ready", &RegisterMap::OutputBits::ready, 0},
    {"alarm", &RegisterMap::OutputBits::alarm, 0},
    {"busy", &RegisterMap::OutputBits::busy, 0},
    {"move", &RegisterMap::OutputBits::move, 0},
    {"in_position", &RegisterMap::OutputBits::in_position, 0},
}};

template <typename Bits, std::size_t N>
void read_bits(const nlohmann::json* j, const std::string& context,
               const std::array<BitField<Bits>, N>& fields, Bits& bits) {
  if (j == nullptr) return;
  ObjectReader r(*j, context);
  for (const auto& f : fields) {
    const auto v = r.optional<long long>(f.name, bits.*(f.member));
    if (v < f.lowest || v > 15) throw Error::out_of_range(r.path(f.name), static_cast<double>(v), f.lowest, 15);
    bits.*(f.member) = static_cast<int>(v);
  }
  r.finish();
}

template <typename Bits, std::size_t N>
void check_distinct_bits(const std::string& context, const std::array<BitField<Bits>, N>& fields,
                         const Bits& bits) {
  for (std::size_t a = 0; a < N; ++a)
    for (std::size_t b = a + 1; b < N; ++b) {
      const int va = bits.*(fields[a].member);
      if (va >= 0 && va == bits.*(fields[b].member))
        throw Error::invalid(join_field(context, fields[b].name),
                             fmt::format("bit {} is already used by '{}'", va, fields[a].name));
    }
}

}  // namespace

RegisterMap RegisterMap::preset(std::string_view name) {
  if (name == "az") return RegisterMap{};
  throw Error(Errc::not_found,
              fmt::format("unknown register map preset '{}' (known: az)", name), "preset");
}

std::uint16_t parse_register_address(const nlohmann::json& j, const std::string& field) {
  long long v = 0;
  if (j.is_number_integer()) {
    v = j.get<long long>();
  } else if (j.is_string()) {
    const auto& s = j.get_ref<const std::string&>();
    const bool hex = s.size() > 2 && s[0] == '0' && (s[1] == 'x' || s[1] == 'X');
    const std::string digits = hex ? s.substr(2) : s;
    if (digits.empty() || digits.size() > 8 ||
        !std::all_of(digits.begin(), digits.end(), [&](char c) {
          return hex ? std::isxdigit(static_cast<unsigned char>(c)) != 0
                     : std::isdigit(static_cast<unsigned char>(c)) != 0;
        }))
      throw Error::invalid(field, fmt::format("'{}' is not a register address (0..65535 or "
                                              "0x0000..0xFFFF)", s));
    v = std::stoll(digits, nullptr, hex ? 16 : 10);
  } else {
    throw Error::invalid(field, "expected a register address (integer or \"0x...\"), got " +
                                    json_util::type_name(j));
  }
  if (v < 0 || v > 0xFFFF) throw Error::out_of_range(field, static_cast<double>(v), 0, 65535);
  return static_cast<std::uint16_t>(v);
}

RegisterMap RegisterMap::from_json(const nlohmann::json& j, const std::string& context) {
  ObjectReader r(j, context);
  const auto preset_name = r.optional<std::string>("preset", "az");
  RegisterMap m;
  try {
    m = preset(preset_name);
  } catch (const Error& e) {
    throw Error(e.code(), e.what(), r.path("preset"));
  }

  if (const auto* regs = r.raw("registers")) {
    ObjectReader rr(*regs, r.path("registers"));
    for (const auto& f : kRegisters)
      if (const auto* v = rr.raw(f.name)) m.*(f.member) = parse_register_address(*v, rr.path(f.name));
    rr.finish();
  }
  read_bits(r.raw("input_bits"), r.path("input_bits"), kInputBits, m.input);
  read_bits(r.raw("output_bits"), r.path("output_bits"), kOutputBits, m.output);

  const auto order = r.optional<std::string>("word_order", "high_first");
  if (order == "high_first") m.word_order = WordOrder::high_first;
  else if (order == "low_first") m.word_order = WordOrder::low_first;
  else throw Error::invalid(r.path("word_order"),
                            fmt::format("'{}' is not one of high_first, low_first", order));

  const auto op = r.optional<long long>("operation_type_absolute", m.operation_type_absolute);
  if (op < std::numeric_limits<std::int32_t>::min() || op > std::numeric_limits<std::int32_t>::max())
    throw Error::out_of_range(r.path("operation_type_absolute"), static_cast<double>(op),
                              std::numeric_limits<std::int32_t>::min(),
                              std::numeric_limits<std::int32_t>::max());
  m.operation_type_absolute = static_cast<std::int32_t>(op);
  const auto trig = r.optional<long long>("trigger_value", m.trigger_value);
  if (trig < std::numeric_limits<std::int32_t>::min() || trig > std::numeric_limits<std::int32_t>::max() || trig == 0)
    throw Error::invalid(r.path("trigger_value"),
                         fmt::format("{} must be a non-zero 32-bit value", trig));
  m.trigger_value = static_cast<std::int32_t>(trig);

  m.rate_unit_hz_per_s = r.optional<double>("rate_unit_hz_per_s", m.rate_unit_hz_per_s);
  if (!(m.rate_unit_hz_per_s >= 1e-6 && m.rate_unit_hz_per_s <= 1e6))
    throw Error::out_of_range(r.path("rate_unit_hz_per_s"), m.rate_unit_hz_per_s, 1e-6, 1e6, " Hz/s");
  m.current_unit_percent = r.optional<double>("current_unit_percent", m.current_unit_percent);
  if (!(m.current_unit_percent >= 1e-4 && m.current_unit_percent <= 100))
    throw Error::out_of_range(r.path("current_unit_percent"), m.current_unit_percent, 1e-4, 100, " %");
  r.finish();
  m.validate(context);
  return m;
}

nlohmann::json RegisterMap::to_json() const {
  nlohmann::json regs = nlohmann::json::object();
  for (const auto& f : kRegisters) regs[f.name] = fmt::format("0x{:04X}", this->*(f.member));
  nlohmann::json in = nlohmann::json::object();
  for (const auto& f : kInputBits) in[f.name] = input.*(f.member);
  nlohmann::json out = nlohmann::json::object();
  for (const auto& f : kOutputBits) out[f.name] = output.*(f.member);
  return {{"registers", regs},
          {"input_bits", in},
          {"output_bits", out},
          {"word_order", word_order == WordOrder::high_first ? "high_first" : "low_first"},
          {"operation_type_absolute", operation_type_absolute},
          {"trigger_value", trigger_value},
          {"rate_unit_hz_per_s", rate_unit_hz_per_s},
          {"current_unit_percent", current_unit_percent}};
}

bool RegisterMap::direct_block() const {
  const std::array<std::uint16_t, 8> order{data_no, operation_type, position, speed,
                                           rate,    stop_rate,      current,  trigger};
  for (std::size_t i = 0; i < order.size(); ++i)
    if (static_cast<long>(order[i]) != static_cast<long>(data_no) + 2 * static_cast<long>(i))
      return false;
  return true;
}

void RegisterMap::validate(const std::string& context) const {
  // Every register a field occupies, so that no two fields share one.
  for (std::size_t a = 0; a < kRegisters.size(); ++a) {
    const long a0 = this->*(kRegisters[a].member);
    const long a1 = a0 + kRegisters[a].width - 1;
    const std::string field = join_field(join_field(context, "registers"), kRegisters[a].name);
    if (a1 > 0xFFFF)
      throw Error::invalid(field, fmt::format("a 32-bit value at 0x{:04X} would run past 0xFFFF", a0));
    for (std::size_t b = 0; b < a; ++b) {
      const long b0 = this->*(kRegisters[b].member);
      const long b1 = b0 + kRegisters[b].width - 1;
      if (a0 <= b1 && b0 <= a1)
        throw Error::invalid(field, fmt::format("registers 0x{:04X}..0x{:04X} overlap '{}' "
                                                "(0x{:04X}..0x{:04X})",
                                                a0, a1, kRegisters[b].name, b0, b1));
    }
  }
  check_distinct_bits(join_field(context, "input_bits"), kInputBits, input);
  check_distinct_bits(join_field(context, "output_bits"), kOutputBits, output);
}

// --- status word ---------------------------------------------------------------------------

StatusBits decode_status(std::uint16_t word, const RegisterMap::OutputBits& bits) noexcept {
  const auto on = [word](int b) { return b >= 0 && b <= 15 && ((word >> b) & 1u) != 0; };
  StatusBits s;
  s.ready = on(bits.ready);
  s.alarm = on(bits.alarm);
  s.busy = on(bits.busy);
  s.moving = on(bits.move);
  s.in_position = on(bits.in_position);
  s.home_end = on(bits.home_end);
  return s;
}

std::uint16_t encode_status(const StatusBits& s, const RegisterMap::OutputBits& bits) noexcept {
  std::uint16_t w = 0;
  const auto set = [&w](int b, bool v) {
    if (v && b >= 0 && b <= 15) w = static_cast<std::uint16_t>(w | (1u << b));
  };
  set(bits.ready, s.ready);
  set(bits.alarm, s.alarm);
  set(bits.busy, s.busy);
  set(bits.move, s.moving);
  set(bits.in_position, s.in_position);
  set(bits.home_end, s.home_end);
  return w;
}

std::uint16_t input_word(int bit) noexcept {
  return bit >= 0 && bit <= 15 ? static_cast<std::uint16_t>(1u << bit) : 0;
}

// --- encoding ----------------------------------------------------------------------------

std::array<std::uint16_t, 2> encode_u32(std::uint32_t v, WordOrder order) noexcept {
  const auto hi = static_cast<std::uint16_t>(v >> 16);
  const auto lo = static_cast<std::uint16_t>(v & 0xFFFFu);
  return order == WordOrder::high_first ? std::array{hi, lo} : std::array{lo, hi};
}

std::uint32_t decode_u32(std::uint16_t first, std::uint16_t second, WordOrder order) noexcept {
  const std::uint32_t hi = order == WordOrder::high_first ? first : second;
  const std::uint32_t lo = order == WordOrder::high_first ? second : first;
  return (hi << 16) | lo;
}

std::array<std::uint16_t, 2> encode_i32(std::int32_t v, WordOrder order) noexcept {
  return encode_u32(static_cast<std::uint32_t>(v), order);
}

std::int32_t decode_i32(std::uint16_t first, std::uint16_t second, WordOrder order) noexcept {
  // Conversion of an out-of-range unsigned value is modular since C++20.
  return static_cast<std::int32_t>(decode_u32(first, second, order));
}

std::int32_t AxisScale::to_steps(double deg, const std::string& field) const {
  const double steps = std::round((deg - zero_deg) * steps_per_degree);
  constexpr double lo = std::numeric_limits<std::int32_t>::min();
  constexpr double hi = std::numeric_limits<std::int32_t>::max();
  if (!std::isfinite(steps) || steps < lo || steps > hi) {
    const double a = zero_deg + lo / steps_per_degree;
    const double b = zero_deg + hi / steps_per_degree;
    throw Error::out_of_range(field, deg, std::min(a, b), std::max(a, b), "°");
  }
  return static_cast<std::int32_t>(steps);
}

double AxisScale::to_degrees(std::int32_t steps) const noexcept {
  return zero_deg + static_cast<double>(steps) / steps_per_degree;
}

double AxisScale::to_step_rate(double deg_per_s) const noexcept {
  return std::abs(deg_per_s * steps_per_degree);
}

}  // namespace gonio::drivers::modbus
