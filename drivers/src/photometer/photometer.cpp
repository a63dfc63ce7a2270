// Small helpers of the Photometer interface shared by every photometer driver.
#include "gonio/drivers/photometer/photometer.hpp"

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio::drivers {

std::string Identity::to_string() const {
  std::string s = manufacturer;
  if (!model.empty()) s += (s.empty() ? "" : " ") + model;
  if (!serial.empty()) s += fmt::format(" ({})", serial);
  if (!firmware.empty()) s += fmt::format(", firmware {}", firmware);
  return s;
}

void check_saturation(const Reading& r, SaturationPolicy policy) {
  if (r.saturated && r.channel != Channel::dark && policy == SaturationPolicy::throw_error)
    throw Error(Errc::saturated,
                fmt::format("detector saturated on the {} channel at {:g} ms integration; "
                            "shorten the integration time",
                            to_text(r.channel), r.integration_ms));
}

}  // namespace gonio::drivers
