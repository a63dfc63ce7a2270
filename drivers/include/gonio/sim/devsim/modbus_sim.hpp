// An AZ-compatible Modbus motion controller simulator: a libmodbus server on TCP (a port
// it binds) and on RTU (a pty it creates), one simulated axis per unit id. Three layers:
// SimAxis (the motion model), SimUnit (the registers of one unit over its axis) and
// ModbusSim (the serving loop).
//
// Each unit holds the holding registers of its register map (preset `az`) and runs a
// motion model: trapezoidal profile from the direct-data speed, acceleration and stop
// rate, finite motion time, SYS-BSY/MOVE while moving, IN-POS when at rest within the
// in-position band of the command position, READY when no alarm, no motion and neither
// STOP nor FREE is on, HOME-END after ZHOME homing. Direct data operation starts when the
// trigger register is written with the map's trigger value (or on a START rising edge);
// the trigger then reads back 0. Inputs: STOP and FREE are levels, ZHOME, ALM-RST and
// START act on their rising edge. Writes to the status and monitor registers are refused
// (exception 02). Requests to unit ids it does not simulate get no answer (as on a
// multi-drop RS-485 bus); broadcasts (unit 0) are ignored.
//
// Scripted faults (config, deterministic): an alarm at the Nth move of a unit (raised
// when the move reaches a fraction of its way; the motor stops there), and a stall at the
// Nth move (the feedback stops at a fraction of the way while the command goes on). Run-
// time faults (tests): mute (requests are read but never answered), dropping every TCP
// client, going offline (connections refused) and back on the same port, corrupting the
// next N replies, raising an alarm.
//
// RTU framing follows MODBUS over Serial Line V1.02 §2.5.1: request length from the
// function code, CRC checked (bad frames are discarded silently, as a slave must).
// With "record" set, every RTU request and reply is appended as a hex line to that file
// ("> 01 03 ..." request, "< 01 03 ..." reply): the format of the golden captures.
//
// Config (JSON, strict):
//   {"tcp": {"host": "127.0.0.1", "port": 0},   // omit for no TCP; port 0: ephemeral
//    "rtu": true,                               // create a pty
//    "motion": "profile" | "instant",           // instant: every motion completes at once
//    "register_map": {"preset": "az"},
//    "record": "capture.txt",
//    "units": [{"unit": 1, "position_steps": 0, "in_position_band_steps": 2,
//               "home_position_steps": 0, "home_speed_hz": 20000, "home_accel_hz_s": 200000,
//               "alarm_at_move": {"move": 3, "code": 48, "fraction": 0.5},
//               "stall_at_move": {"move": 2, "fraction": 0.5}}]}
#pragma once

#include <atomic>
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "gonio/drivers/modbus/register_map.hpp"

namespace gonio::drivers::devsim {

struct SimFault {
  int move = 0;           // 1-based number of the move (direct data operation) it hits
  double fraction = 0.5;  // of the way from start to target
  std::uint32_t code = 0x30;  // alarm code (alarm faults)
};

struct SimAxisConfig {
  int unit = 1;
  std::int32_t position_steps = 0;
  double in_position_band_steps = 2;
  std::int32_t home_position_steps = 0;
  double home_speed_hz = 20000;
  double home_accel_hz_s = 200000;
  std::optional<SimFault> alarm_at_move;
  std::optional<SimFault> stall_at_move;
};

// Alarm code the AZ uses for invalid operation data.
inline constexpr std::uint32_t kOperationDataError = 0x70;

// The motion model of one axis, in steps and seconds; no I/O, no clock of its own.
class SimAxis {
 public:
  SimAxis(SimAxisConfig config, bool instant);

  const SimAxisConfig& config() const noexcept { return cfg_; }

  // Integrates the motion over `seconds` (in steps of at most 1 ms).
  void advance(double seconds);

  // Direct data operation, absolute positioning. Ignored when not ready. Invalid data
  // (speed or rates <= 0) raises alarm 0x70 (operation data error).
  void start_move(std::int32_t target, double speed_hz, double accel_hz_s, double decel_hz_s);
  void start_home();
  void set_stop(bool on);  // deceleration stop while on; not ready while on
  void set_free(bool on);  // de-energised: not ready
  void reset_alarm();
  void raise_alarm(std::uint32_t code);  // stops at once

  std::int32_t command() const noexcept;
  std::int32_t feedback() const noexcept;
  bool moving() const noexcept { return mode_ != Mode::idle; }
  bool busy() const noexcept { return moving(); }
  bool in_position() const noexcept;
  bool ready() const noexcept;
  bool home_end() const noexcept { return home_end_; }
  std::uint32_t alarm() const noexcept { return alarm_; }
  int moves_started() const noexcept { return moves_; }

 private:
  enum class Mode { idle, positioning, homing, stopping };
  void begin(double target, double speed, double accel, double decel, Mode mode);
  void step(double h);
  void finish();

  SimAxisConfig cfg_;
  bool instant_;
  Mode mode_ = Mode::idle;
  double cmd_ = 0, v_ = 0, target_ = 0, vmax_ = 0, acc_ = 0, dec_ = 0;
  double start_ = 0;
  std::optional<double> stall_at_;   // feedback freezes once the command passes it
  std::optional<double> alarm_at_;   // alarm once the command passes it
  std::optional<double> frozen_fb_;  // feedback of a stalled motor
  std::uint32_t pending_alarm_ = 0;
  bool stop_ = false, free_ = false, home_end_ = false;
  std::uint32_t alarm_ = 0;
  int moves_ = 0;
};

// One simulated unit as its registers show it: the holding-register image of the map and
// the SimAxis behind it. What a write does (the trigger starts a direct data operation,
// the input command's levels and rising edges) and what a read shows (status word, alarm
// code, feedback and command positions) live here, so that the register behaviour is
// testable without a socket; ModbusSim only frames requests and answers them from this
// image. No clock of its own: advance() is given the elapsed time.
class SimUnit {
 public:
  SimUnit(SimAxisConfig config, modbus::RegisterMap map, bool instant);

  int unit() const noexcept { return axis_.config().unit; }
  const modbus::RegisterMap& map() const noexcept { return map_; }
  const SimAxis& axis() const noexcept { return axis_; }

  // The register image, addresses 0 .. size()-1 (covers every register of the map). The
  // server lets libmodbus read and write it, then calls written().
  std::span<std::uint16_t> registers() noexcept { return regs_; }
  // Whether [first, first+count) touches a status or monitor register (a write there is
  // refused with exception 02).
  bool read_only(int first, int count) const noexcept;

  // Integrates the motion over `seconds`, then refreshes the status and monitor registers.
  void advance(double seconds);
  // Status word, alarm code and positions from the axis.
  void refresh();
  // Acts on what a write of [first, first+count) into registers() changed — the trigger
  // and the input command — then refreshes.
  void written(int first, int count);
  void raise_alarm(std::uint32_t code);

  // Typed access to the image. read() refreshes first. write() stores the values and acts
  // on them; it throws Error(invalid_argument) for a read-only register and
  // Error(out_of_range) outside the image, and then changes nothing.
  std::vector<std::uint16_t> read(int first, int count);
  void write(int first, std::span<const std::uint16_t> values);

 private:
  void put32(std::uint16_t addr, std::uint32_t v);
  std::int32_t get_i32(std::uint16_t addr) const;
  void start_direct();
  void check_range(int first, int count, const char* what) const;

  modbus::RegisterMap map_;
  SimAxis axis_;
  std::vector<std::uint16_t> regs_;
  std::uint16_t inputs_ = 0;  // last input command word, for rising edges
};

struct ModbusSimConfig {
  std::optional<std::string> tcp_host;  // TCP server when set
  int tcp_port = 0;
  bool rtu = false;
  bool instant = false;
  modbus::RegisterMap map;
  std::vector<SimAxisConfig> units;
  std::string record_path;

  static ModbusSimConfig from_json(const nlohmann::json& j);
};

struct SimAxisSnapshot {
  std::int32_t command = 0;
  std::int32_t feedback = 0;
  bool moving = false;
  bool ready = false;
  bool home_end = false;
  std::uint32_t alarm = 0;
  int moves = 0;
};

class ModbusSim {
 public:
  explicit ModbusSim(ModbusSimConfig config);
  ~ModbusSim();
  ModbusSim(const ModbusSim&) = delete;
  ModbusSim& operator=(const ModbusSim&) = delete;

  // Binds the TCP port and/or creates the pty, then serves on a thread of its own.
  // Throws Error(io_error) when the port or the pty cannot be had.
  void start();
  void stop();

  int tcp_port() const;                 // the bound port (after start)
  const std::string& rtu_path() const;  // the pty's slave path, e.g. /dev/pts/7

  // Faults.
  void set_mute(bool mute);
  void drop_connections();
  void set_offline(bool offline);
  void corrupt_next_replies(int count);
  void raise_alarm(int unit, std::uint32_t code);

  // Observation.
  std::uint64_t requests() const;  // frames received, for any unit
  SimAxisSnapshot axis(int unit) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The gonio-devsim entry: builds a simulator from `config`, prints one line per endpoint
// to `out` ("modbus-tcp 127.0.0.1:5020", "modbus-rtu /dev/pts/7", as gonio-devsim prints
// them), serves until `stop`
// becomes true (checked every 50 ms) and returns 0. Config errors throw gonio::Error.
int run_modbus_sim(const nlohmann::json& config, std::ostream& out, const std::atomic<bool>& stop);

}  // namespace gonio::drivers::devsim
