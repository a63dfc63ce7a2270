// The alert.* methods: listing (standing, resolved or all) and acknowledging alerts.
#include <fmt/format.h>

#include "methods/params.hpp"
#include "methods/registrar.hpp"

namespace gonio::daemon {

using json_util::ObjectReader;
using nlohmann::json;

void register_alert(MethodRegistrar& reg, Services& s) {
  reg.add("alert.list", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    AlertFilter f;
    if (const auto* a = r.raw("acknowledged"); a && !a->is_null())
      f.acknowledged = json_util::get_as<bool>(*a, "acknowledged");
    if (const auto* sc = r.raw("scan"); sc && !sc->is_null()) {
      f.scan_id = json_util::get_as<std::int64_t>(*sc, "scan");
      if (*f.scan_id <= 0) throw Error::invalid("scan", "is not an id (ids are >= 1)");
    }
    // standing | resolved | all (the default: every alert, as before resolution existed).
    if (const auto* st = r.raw("state"); st && !st->is_null()) {
      const auto state = json_util::get_as<std::string>(*st, "state");
      if (state == "standing") f.resolved = false;
      else if (state == "resolved") f.resolved = true;
      else if (state != "all")
        throw Error::invalid("state", fmt::format("'{}' is not one of: standing, resolved, all", state));
    }
    if (const auto* sv = r.raw("severity"); sv && !sv->is_null())
      f.min_severity = parse_enum<Severity>(json_util::get_as<std::string>(*sv, "severity"), "severity");
    f.offset = methods::read_offset(r);
    f.limit = methods::read_count(r, "limit", 100, methods::kMaxPage);
    r.finish();
    json out = json::array();
    for (const auto& a : s.store.alerts(f)) out.push_back(a);
    return out;
  });

  reg.add("alert.ack", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto id = methods::read_id(r, "alert");
    r.finish();
    return json(s.alerts.ack(id, methods::actor(c)));
  });
}

}  // namespace gonio::daemon
