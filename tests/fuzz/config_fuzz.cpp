// Fuzz target: goniod's TOML configuration as an operator writes it — parse, strict key and
// range checks, the cross-field rules, and the instrument's driver tables as far as they
// are read without opening a device (the motion guard from the limits table). A bad file
// must end in gonio::Error naming the key; any other exception, a crash or a hang is a
// finding.
#include <cstdint>
#include <string_view>

#include <spdlog/spdlog.h>

#include "gonio/daemon/config/config.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/registry/registry.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  spdlog::set_level(spdlog::level::off);
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const auto c = gonio::daemon::Config::parse(text, "fuzz.toml");
    c.validate();
    // The guard reads the motion table's driver (and for the mock, its profile).
    (void)gonio::drivers::motion_guard(c.limits, c.motion);
  } catch (const gonio::Error&) {
  }
  return 0;
}
