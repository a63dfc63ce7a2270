// The archive.* methods: the central archive's backlog, and shipping a scan again.
#include <fmt/format.h>

#include "methods/params.hpp"
#include "methods/registrar.hpp"

namespace gonio::daemon {

using json_util::ObjectReader;
using nlohmann::json;

void register_archive(MethodRegistrar& reg, Services& s) {
  reg.add("archive.status", [&s](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    if (!s.archive) return json{{"configured", false}};
    json out = s.archive->status();
    out["configured"] = true;
    return out;
  });

  reg.add("archive.reship", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto id = methods::read_id(r, "scan");
    r.finish();
    if (!s.archive)
      throw Error(Errc::unsupported, "archive: goniod has no [archive] configured", "archive");
    const auto rows = s.store.outbox_reship(id, methods::actor(c));
    s.archive->wake();
    return json{{"scan", id}, {"queued", rows}};
  });
}

}  // namespace gonio::daemon
