// subscribe and unsubscribe: notification topics of a persistent connection.
#include <optional>
#include <set>

#include <fmt/format.h>

#include "methods/params.hpp"
#include "methods/registrar.hpp"

namespace gonio::daemon {

using json_util::ObjectReader;
using nlohmann::json;

void register_subscribe(MethodRegistrar& reg, Services& s) {
  reg.add("subscribe", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    std::set<Topic> topics;
    if (const auto* t = r.raw("topics"); t && !t->is_null()) {
      if (!t->is_array() || t->empty())
        throw Error::invalid("topics", "expected a non-empty array (progress, points, alerts, state)");
      for (std::size_t i = 0; i < t->size(); ++i) {
        const auto field = fmt::format("topics[{}]", i);
        topics.insert(parse_enum<Topic>(json_util::get_as<std::string>((*t)[i], field), field));
      }
    } else {
      topics = {Topic::progress, Topic::points, Topic::alerts, Topic::state};
    }
    std::optional<std::int64_t> scan;
    if (const auto* sc = r.raw("scan"); sc && !sc->is_null()) {
      scan = json_util::get_as<std::int64_t>(*sc, "scan");
      (void)methods::require_scan(s.store, *scan);
    }
    r.finish();
    if (!c.session->persistent())
      throw Error(Errc::unsupported,
                  "subscriptions need a persistent connection (NDJSON socket or WebSocket), not "
                  "HTTP POST");
    s.hub.subscribe(c.session, topics, scan);
    json names = json::array();
    for (auto t : s.hub.topics(c.session->id())) names.push_back(to_text(t));
    return json{{"topics", std::move(names)}, {"scan", scan ? json(*scan) : json(nullptr)}};
  });

  reg.add("unsubscribe", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    std::set<Topic> topics;
    if (const auto* t = r.raw("topics"); t && !t->is_null()) {
      if (!t->is_array()) throw Error::invalid("topics", "expected an array");
      for (std::size_t i = 0; i < t->size(); ++i) {
        const auto field = fmt::format("topics[{}]", i);
        topics.insert(parse_enum<Topic>(json_util::get_as<std::string>((*t)[i], field), field));
      }
    }
    r.finish();
    json names = json::array();
    for (auto t : s.hub.unsubscribe(c.session->id(), topics)) names.push_back(to_text(t));
    return json{{"topics", std::move(names)}};
  });
}

}  // namespace gonio::daemon
