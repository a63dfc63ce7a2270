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

#include "gonio/daemon/config/config.hpp"

namespace gonio::daemon {

struct MethodSpec {
  std::string_view name;
  Role role = Role::viewer;  // Role::none: callable before authentication
  bool blocking = false;
  bool control = false;  // runs on the control executor
};

inline constexpr std::array kMethodTable{
    // rpc, auth
    MethodSpec{.name = "rpc.discover", .role = Role::none},
    MethodSpec{.name = "auth.login", .role = Role::none},
    MethodSpec{.name = "auth.whoami", .role = Role::viewer},
    MethodSpec{.name = "auth.create_token", .role = Role::admin},
    MethodSpec{.name = "auth.list_tokens", .role = Role::admin},
    MethodSpec{.name = "auth.revoke_token", .role = Role::admin},
    // system
    MethodSpec{.name = "system.info", .role = Role::viewer},
    MethodSpec{.name = "system.audit", .role = Role::admin},
    // instrument
    MethodSpec{.name = "instrument.status", .role = Role::viewer},
    MethodSpec{.name = "instrument.home", .role = Role::technician, .blocking = true},
    MethodSpec{.name = "instrument.move", .role = Role::technician, .blocking = true},
    MethodSpec{.name = "instrument.stop", .role = Role::technician},  // inline: immediate, never queued
    MethodSpec{.name = "instrument.reset", .role = Role::technician, .blocking = true, .control = true},
    MethodSpec{.name = "instrument.calibrate", .role = Role::admin, .blocking = true},
    // samples
    MethodSpec{.name = "sample.create", .role = Role::technician, .blocking = true},
    MethodSpec{.name = "sample.get", .role = Role::viewer},
    MethodSpec{.name = "sample.list", .role = Role::viewer},
    MethodSpec{.name = "sample.export", .role = Role::viewer},
    // scans
    MethodSpec{.name = "scan.submit", .role = Role::technician, .blocking = true},
    MethodSpec{.name = "scan.get", .role = Role::viewer},
    MethodSpec{.name = "scan.list", .role = Role::viewer},
    MethodSpec{.name = "scan.pause", .role = Role::technician, .blocking = true, .control = true},
    MethodSpec{.name = "scan.resume", .role = Role::technician, .blocking = true, .control = true},
    MethodSpec{.name = "scan.cancel", .role = Role::technician, .blocking = true, .control = true},
    MethodSpec{.name = "scan.points", .role = Role::viewer, .blocking = true},  // a page is up to megabytes: with the exports
    MethodSpec{.name = "scan.export", .role = Role::viewer, .blocking = true},
    MethodSpec{.name = "scan.fit", .role = Role::technician, .blocking = true},
    MethodSpec{.name = "scan.material", .role = Role::technician, .blocking = true},
    // queue
    MethodSpec{.name = "queue.status", .role = Role::viewer},
    MethodSpec{.name = "queue.reorder", .role = Role::technician},
    // alerts
    MethodSpec{.name = "alert.list", .role = Role::viewer},
    MethodSpec{.name = "alert.ack", .role = Role::technician},
    // central archive
    MethodSpec{.name = "archive.status", .role = Role::viewer},
    MethodSpec{.name = "archive.reship", .role = Role::technician, .blocking = true},
    // backups of the store
    MethodSpec{.name = "backup.create", .role = Role::admin, .blocking = true},
    MethodSpec{.name = "backup.read", .role = Role::admin, .blocking = true},
    // twin
    MethodSpec{.name = "twin.predict", .role = Role::technician, .blocking = true},
    // subscriptions
    MethodSpec{.name = "subscribe", .role = Role::viewer},
    MethodSpec{.name = "unsubscribe", .role = Role::viewer},
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
