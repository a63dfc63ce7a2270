// goniod's instrument tables before the drivers see them (not a public header).
#pragma once

#include "gonio/daemon/config/config.hpp"

namespace gonio::daemon {

// A driver name the registry does not know is an error naming the key and the known names,
// with --mock or without (a typo is neither "no instrument configured" nor silently the
// mock). With `mock`, a configured motion table that is not the mock's is replaced by the
// mock lab (never drive real arms by accident), and a warning in `c.warnings` says what
// was replaced, for the log and --check-config.
void settle_instrument_tables(Config& c, bool mock);

}  // namespace gonio::daemon
