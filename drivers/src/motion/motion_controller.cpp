// Small functions of the MotionController interface shared by every motion driver: axis names
// and the human form of an axis status.
#include "gonio/drivers/motion/motion_controller.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio::drivers {

std::string to_string(const AxisStatus& s) {
  std::string flags;
  const auto add = [&](bool on, std::string_view word) {
    if (on) flags += (flags.empty() ? "" : " ") + std::string(word);
  };
  add(s.ready, "ready");
  add(s.busy, "busy");
  add(s.moving, "moving");
  add(s.in_position, "in-position");
  add(s.home_end, "home-end");
  if (flags.empty()) flags = "not-ready";
  std::string text = fmt::format("{} at {:.4f}° (command {:.4f}°)", flags, s.position_deg,
                                 s.command_deg);
  if (s.alarm) text += fmt::format(", ALARM 0x{:02X}", s.alarm_code);
  return text;
}

bool MotionController::has_axis(Axis a) const {
  const auto all = axes();
  return std::find(all.begin(), all.end(), a) != all.end();
}

}  // namespace gonio::drivers
