// The instrument.* methods: status and manual control (home, move, stop, reset).
#include <cmath>
#include <map>
#include <vector>

#include <fmt/format.h>

#include "gonio/drivers/motion/motion_controller.hpp"
#include "methods/params.hpp"
#include "methods/registrar.hpp"

namespace gonio::daemon {

using json_util::ObjectReader;
using methods::actor;
using nlohmann::json;

namespace {

// The axes given in params ("incidence", "receive", ...), in degrees.
std::map<drivers::Axis, double> read_targets(ObjectReader& r) {
  std::map<drivers::Axis, double> t;
  for (auto a : drivers::kAllAxes) {
    const std::string key(to_text(a));
    if (r.has(key)) t[a] = r.required<double>(key);
  }
  return t;
}

}  // namespace

void register_instrument(MethodRegistrar& reg, Services& s) {
  reg.add("instrument.status", [&s](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    return s.instrument.status();
  });

  reg.add("instrument.home", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    std::vector<drivers::Axis> axes;
    if (const auto* a = r.raw("axes"); a && !a->is_null()) {
      if (!a->is_array()) throw Error::invalid("axes", "expected an array of axis names");
      for (std::size_t i = 0; i < a->size(); ++i) {
        const auto field = fmt::format("axes[{}]", i);
        axes.push_back(parse_enum<drivers::Axis>(json_util::get_as<std::string>((*a)[i], field), field));
      }
    }
    r.finish();
    return s.instrument.home(axes, actor(c));
  });

  reg.add("instrument.move", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto targets = read_targets(r);
    r.finish();
    if (targets.empty())
      throw Error::invalid("params", "give at least one of incidence, receive, rotation, tilt "
                                     "(degrees)");
    for (const auto& [axis, deg] : targets)
      if (!std::isfinite(deg))
        throw Error::invalid(std::string(to_text(axis)), "must be a finite number");
    return s.instrument.move(targets, actor(c));
  });

  reg.add("instrument.stop", [&s](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    return s.instrument.stop(actor(c));
  });

  reg.add("instrument.reset", [&s](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    return s.instrument.reset(actor(c));
  });
}

}  // namespace gonio::daemon
