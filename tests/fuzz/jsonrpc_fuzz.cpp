// Fuzz target: the JSON-RPC request path of goniod — parse, validate the params, dispatch
// to the real method handlers of a daemon on the mock (daemon_fuzz.hpp) — with every reply
// checked for well-formed JSON-RPC 2.0. The first byte picks the caller's role (none,
// viewer, technician, admin), the rest is the message (a request, a notification or a
// batch). Anything but a well-formed reply (an escaped exception, a crash, a reply that is
// not JSON-RPC) is a finding.
#include <cstdint>
#include <optional>
#include <string>

#include "daemon_fuzz.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  using gonio::daemon::Role;
  static const Role roles[] = {Role::none, Role::viewer, Role::technician, Role::admin};
  auto& d = gonio::fuzz::FuzzDaemon::get();
  const std::string_view text(reinterpret_cast<const char*>(data) + 1, size - 1);
  std::optional<std::string> reply;
  d.dispatcher.handle(text, std::make_shared<gonio::fuzz::FuzzSession>(roles[data[0] % 4]),
                      [&](std::string r) { reply = std::move(r); });
  if (!reply) gonio::fuzz::fail("the dispatcher did not answer", "");
  gonio::fuzz::check_reply(*reply);
  return 0;
}
