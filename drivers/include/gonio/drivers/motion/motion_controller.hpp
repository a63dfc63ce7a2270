// MotionController — the arms and sample stage of the goniometer (docs/architecture.md §4).
//
// Four named axes, all in degrees in the sample frame of docs/architecture.md §2:
//   incidence  θi, the source arm
//   receive    θr, the receiver arm (signed: θr = θi is specular, θr = −θi retro-reflection)
//   rotation   sample rotation about its normal (azimuth)
//   tilt       sample tilt
// A controller drives a subset of them (axes()); the others throw Error(unsupported).
//
// Moves are absolute and blocking: move() returns when the axis is in position at the
// target, or throws. Drivers check no soft limits and no arm collision: GuardedMotion
// (motion/guarded_motion.hpp), which wraps every controller an instrument opens, checks
// them before a move reaches the driver. Every call blocks for at most its timeout and
// fails with gonio::Error:
//   timeout          the device did not answer, or the motion did not finish, in time
//   disconnected     the link dropped and could not be re-established before the deadline
//   device_alarm     the device reports an alarm (its code, in hex, is in the message), or
//                    the axis stopped away from its command position (following error)
//   protocol_error   the device answered with bytes that break its protocol, or refused a
//                    request (Modbus exception)
//   limit_violation  the target is outside the soft limits or inside the collision zone;
//                    the message names the axis, the target and the limit
//   busy             the axis is not ready to accept a command (moving, de-energised)
//   invalid_state    the move or homing was interrupted by stop()
// A controller is used from one thread at a time, except stop(), which may be called from
// any thread while another call is in progress.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "gonio/proto/enum_text.hpp"

namespace gonio::drivers {

using std::chrono::milliseconds;

enum class Axis : std::uint8_t { incidence, receive, rotation, tilt };

inline constexpr std::array<Axis, 4> kAllAxes{Axis::incidence, Axis::receive, Axis::rotation,
                                               Axis::tilt};

inline constexpr EnumNames<Axis, 4> kAxisNames{{
    {Axis::incidence, "incidence"},
    {Axis::receive, "receive"},
    {Axis::rotation, "rotation"},
    {Axis::tilt, "tilt"},
}};
constexpr const auto& enum_names(Axis) { return kAxisNames; }  // proto/enum_text.hpp

struct AxisStatus {
  bool ready = false;        // accepts a motion command (no alarm, not moving, energised)
  bool busy = false;         // the controller is processing a command
  bool moving = false;       // the motor is moving
  bool in_position = false;  // at rest within the in-position band of the command position
  bool alarm = false;        // an alarm is present
  std::uint32_t alarm_code = 0;  // device alarm code (0: none)
  bool home_end = false;     // homing completed and the axis has not moved since (false if
                             // the device has no such signal)
  double position_deg = 0;   // feedback (encoder) position
  double command_deg = 0;    // command (profile) position
  friend bool operator==(const AxisStatus&, const AxisStatus&) = default;
};

// "ready in-position 12.5° (command 12.5°)" / "ALARM 0x30 ..." — for logs and tools.
std::string to_string(const AxisStatus& s);

struct MotionCapabilities {
  bool homing = true;         // home() is supported
  bool alarm_reset = true;    // reset_alarm() is supported
  bool feedback = true;       // position_deg is an encoder reading, not the command
};

class MotionController {
 public:
  virtual ~MotionController() = default;
  MotionController() = default;
  MotionController(const MotionController&) = delete;
  MotionController& operator=(const MotionController&) = delete;

  virtual MotionCapabilities capabilities() const = 0;
  // The axes this controller drives, in a fixed order.
  virtual std::vector<Axis> axes() const = 0;
  bool has_axis(Axis a) const;

  // Moves `axis` to `target_deg` and waits until it is in position.
  virtual void move(Axis axis, double target_deg, milliseconds timeout) = 0;
  // Feedback position in degrees.
  virtual double position(Axis axis, milliseconds timeout) = 0;
  virtual AxisStatus status(Axis axis, milliseconds timeout) = 0;
  // Runs the axis's homing sequence and waits until it completes.
  virtual void home(Axis axis, milliseconds timeout) = 0;
  // Where homing leaves `axis`, in degrees, when the controller knows it; the motion guard
  // checks the path there like a move's. Empty: unknown (homing is then not path-checked).
  virtual std::optional<double> home_position(Axis axis) const {
    (void)axis;
    return std::nullopt;
  }
  // Clears a latched alarm; throws Error(device_alarm) if the alarm persists.
  virtual void reset_alarm(Axis axis, milliseconds timeout) = 0;

  // Stops every axis now (deceleration stop). Any thread: a move() or home() in progress
  // fails with Error(invalid_state) soon after. Throws only if the stop could not be sent
  // to some axis within `timeout` (the stop request is still latched for the others).
  virtual void stop(milliseconds timeout) = 0;
};

}  // namespace gonio::drivers
