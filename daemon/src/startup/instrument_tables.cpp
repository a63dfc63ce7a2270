// goniod's instrument tables before the drivers see them (see instrument_tables.hpp).
#include "startup/instrument_tables.hpp"

#include <string>
#include <vector>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"
#include "gonio/registry/registry.hpp"

namespace gonio::daemon {
namespace {

std::string driver_of(const nlohmann::json& side) {
  const auto it = side.find("driver");
  return it != side.end() && it->is_string() ? it->get<std::string>() : std::string();
}

void check_driver_name(const nlohmann::json& side, const std::string& key) {
  const auto name = driver_of(side);
  if (side.empty() || name.empty()) return;  // absent tables and keys: the registry's errors
  std::vector<std::string> known;
  for (const auto& d : drivers::drivers()) {
    if (d.name == name) return;
    known.emplace_back(d.name);
  }
  std::string list;
  for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
  throw Error::invalid(key, fmt::format("'{}' is not a driver{}; the drivers are {}", name,
                                        text::did_you_mean(name, known), list));
}

}  // namespace

void settle_instrument_tables(Config& c, bool mock) {
  check_driver_name(c.motion, "instrument.motion.driver");
  check_driver_name(c.photometer, "instrument.photometer.driver");
  if (!mock || driver_of(c.motion) == "mock") return;
  const auto m = Config::mock_defaults();
  c.warnings.push_back(fmt::format(
      "--mock replaces the configured instrument (motion driver '{}', photometer driver '{}') with "
      "the mock lab and its default sample; to keep a table of your own, set driver = \"mock\" in it",
      driver_of(c.motion), c.photometer.empty() ? std::string("-") : driver_of(c.photometer)));
  c.motion = m.motion;
  c.photometer = m.photometer;
}

}  // namespace gonio::daemon
