// The queue.* methods: what runs, what waits, and moving a waiting scan.
#include "methods/params.hpp"
#include "methods/registrar.hpp"

namespace gonio::daemon {

using json_util::ObjectReader;
using methods::scan_summary;
using nlohmann::json;

void register_queue(MethodRegistrar& reg, Services& s) {
  reg.add("queue.status", [&s](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    const auto running = s.instrument.running_scan();
    json waiting = json::array();
    for (const auto& x : s.store.queue()) waiting.push_back(scan_summary(x));
    json run = nullptr;
    if (running)
      if (auto sc = s.store.scan(*running)) run = scan_summary(*sc);
    return json{{"running", std::move(run)},
                {"waiting", std::move(waiting)},
                {"instrument", s.instrument.status()["state"]}};
  });

  reg.add("queue.reorder", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto id = methods::read_id(r, "scan");
    if (!r.has("position")) throw Error::invalid("position", "is required (0 = next)");
    const auto position = methods::read_count(r, "position", 0, 1000000);
    r.finish();
    (void)methods::require_scan(s.store, id);
    s.store.reorder(id, position, methods::actor(c));
    s.instrument.wake();
    json waiting = json::array();
    for (const auto& x : s.store.queue()) waiting.push_back(scan_summary(x));
    return json{{"waiting", std::move(waiting)}};
  });
}

}  // namespace gonio::daemon
