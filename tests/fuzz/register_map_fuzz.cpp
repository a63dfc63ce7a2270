// Fuzz target: the Modbus register-map configuration (JSON from a config file, outside
// text). Every input must either read into a valid map or be rejected with gonio::Error;
// an accepted map must validate and survive a round trip through to_json. The same bytes
// are also tried as the register_map of an axis in a whole motion driver config.
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include <nlohmann/json.hpp>

#include "gonio/drivers/modbus/modbus_motion.hpp"
#include "gonio/drivers/modbus/register_map.hpp"
#include "gonio/proto/error.hpp"

namespace mb = gonio::drivers::modbus;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto j = nlohmann::json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return 0;
  try {
    const auto map = mb::RegisterMap::from_json(j, "register_map");
    map.validate("register_map");
    if (!(mb::RegisterMap::from_json(map.to_json(), "register_map") == map)) std::abort();
  } catch (const gonio::Error&) {
  }
  try {
    const nlohmann::json cfg{
        {"links", {{"bus", {{"type", "rtu"}, {"device", "/dev/null"}}}}},
        {"axes", {{"tilt", {{"unit", 1}, {"steps_per_degree", 100}, {"register_map", j}}}}}};
    const auto c = mb::MotionConfig::from_json(cfg);
    if (c.axes.size() != 1) std::abort();
  } catch (const gonio::Error&) {
  }
  return 0;
}
