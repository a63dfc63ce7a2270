// The table of goniod's JSON-RPC methods: each method's name, the least role that may call
// it and whether it blocks (runs on the worker executor rather than a network thread).
// Control methods (pausing, resuming and cancelling scans, stopping and resetting the
// instrument) run on an executor of their own: a flood of slow viewer work on the workers
// cannot delay a technician's pause.
//
// This is the one place where a method's role is stated in code. The handlers in
// daemon/src/methods/ attach to the entries by name (an entry without a handler, or a
// handler without an entry, stops goniod at start), and a unit test holds the table to the
// x-role of each method in proto/openrpc.json and to the method table in daemon/README.md.
#pragma once

#include <array>
#include <string_view>

#include "gonio/daemon/config.hpp"

namespace gonio::daemon {

struct MethodSpec {
  std::string_view name;
  Role role = Role::viewer;  // Role::none: callable before authentication
  bool blocking = false;
  bool control = false;  // runs on the control executor
};

inline constexpr std::array kMethodTable{
    // rpc, auth
    MethodSpec{"rpc.discover", Role::none, false},
    MethodSpec{"auth.login", Role::none, false},
    MethodSpec{"auth.whoami", Role::viewer, false},
    MethodSpec{"auth.create_token", Role::admin, false},
    MethodSpec{"auth.list_tokens", Role::admin, false},
    MethodSpec{"auth.revoke_token", Role::admin, false},
    // system
    MethodSpec{"system.info", Role::viewer, false},
    MethodSpec{"system.audit", Role::admin, false},
    // instrument
    MethodSpec{"instrument.status", Role::viewer, false},
    MethodSpec{"instrument.home", Role::technician, true},
    MethodSpec{"instrument.move", Role::technician, true},
    MethodSpec{"instrument.stop", Role::technician, false},  // inline: immediate, never queued
    MethodSpec{"instrument.reset", Role::technician, true, true},
    MethodSpec{"instrument.calibrate", Role::admin, true},
    // samples
    MethodSpec{"sample.create", Role::technician, true},
    MethodSpec{"sample.get", Role::viewer, false},
    MethodSpec{"sample.list", Role::viewer, false},
    // scans
    MethodSpec{"scan.submit", Role::technician, true},
    MethodSpec{"scan.get", Role::viewer, false},
    MethodSpec{"scan.list", Role::viewer, false},
    MethodSpec{"scan.pause", Role::technician, true, true},
    MethodSpec{"scan.resume", Role::technician, true, true},
    MethodSpec{"scan.cancel", Role::technician, true, true},
    MethodSpec{"scan.points", Role::viewer, false},
    MethodSpec{"scan.export", Role::viewer, true},
    MethodSpec{"scan.fit", Role::technician, true},
    // queue
    MethodSpec{"queue.status", Role::viewer, false},
    MethodSpec{"queue.reorder", Role::technician, false},
    // alerts
    MethodSpec{"alert.list", Role::viewer, false},
    MethodSpec{"alert.ack", Role::technician, false},
    // central archive
    MethodSpec{"archive.status", Role::viewer, false},
    MethodSpec{"archive.reship", Role::technician, true},
    // twin
    MethodSpec{"twin.predict", Role::technician, true},
    // subscriptions
    MethodSpec{"subscribe", Role::viewer, false},
    MethodSpec{"unsubscribe", Role::viewer, false},
};

// The entry named `name`, nullptr when the table has none.
constexpr const MethodSpec* find_method_spec(std::string_view name) noexcept {
  for (const auto& m : kMethodTable)
    if (m.name == name) return &m;
  return nullptr;
}

namespace detail {
constexpr bool method_names_unique() {
  for (std::size_t i = 0; i < kMethodTable.size(); ++i)
    for (std::size_t j = i + 1; j < kMethodTable.size(); ++j)
      if (kMethodTable[i].name == kMethodTable[j].name) return false;
  return true;
}
}  // namespace detail
static_assert(detail::method_names_unique(), "a method is listed twice in kMethodTable");

}  // namespace gonio::daemon
