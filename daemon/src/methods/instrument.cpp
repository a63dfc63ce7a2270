// The instrument.* methods: status, manual control (home, move, stop, reset) and
// self-calibration.
#include <algorithm>
#include <cmath>
#include <map>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include "gonio/drivers/motion/motion_controller.hpp"
#include "methods/inverse.hpp"
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

// "fit": the instrument parameters to calibrate, each once, from twin::calibration_parameters().
std::vector<std::string> read_calibration_parameters(ObjectReader& r) {
  const auto& known = twin::calibration_parameters();
  const auto* a = r.raw("fit");
  if (a == nullptr) throw Error::invalid("fit", fmt::format("is required: a list of {}", fmt::join(known, ", ")));
  if (!a->is_array() || a->empty() || a->size() > known.size())
    throw Error::invalid("fit", fmt::format("expected a list of 1 to {} of {}", known.size(),
                                            fmt::join(known, ", ")));
  std::vector<std::string> out;
  for (std::size_t i = 0; i < a->size(); ++i) {
    const auto field = fmt::format("fit[{}]", i);
    auto name = json_util::get_as<std::string>((*a)[i], field);
    if (std::find(known.begin(), known.end(), name) == known.end())
      throw Error::invalid(field, fmt::format("unknown parameter '{}'; expected one of {}", name,
                                              fmt::join(known, ", ")));
    if (std::find(out.begin(), out.end(), name) != out.end())
      throw Error::invalid(field, fmt::format("'{}' is listed twice", name));
    out.push_back(std::move(name));
  }
  return out;
}

// Why a calibration result must not replace the profile, or empty when it may: a profile
// made of parameters the data cannot determine would spoil every later prediction.
std::string not_applicable(const twin::FitResult& f) {
  if (!f.profile) return "the fit made no profile";
  if (!f.converged) return fmt::format("the fit did not converge ({})", f.status);
  for (const auto& p : f.parameters) {
    if (p.at_bound) return fmt::format("{} ended on a bound of its range", p.name);
    if (!p.identifiable) return fmt::format("the data cannot determine {} (see degenerate)", p.name);
  }
  if (!f.degenerate.empty()) return "the data cannot separate the fitted parameters (see degenerate)";
  return {};
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

  // Self-calibration from a scan of a known sample (twin/fitting.md): the listed instrument
  // parameters are fitted through the twin of the current profile; the corrected profile
  // becomes the next stored version, used by every scan started afterwards.
  reg.add("instrument.calibrate", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto id = methods::read_id(r, "scan");
    const auto parameters = read_calibration_parameters(r);
    std::optional<std::string> sample;
    if (const auto* v = r.raw("sample"); v != nullptr && !v->is_null())
      sample = json_util::get_as<std::string>(*v, "sample");
    const bool dry_run = r.optional<bool>("dry_run", false);
    const auto options = methods::read_fit_options(r, s.twin);
    r.finish();
    if (sample && (sample->empty() || sample->size() > 4096))
      throw Error::invalid("sample", "give the known sample's BSDF spec, 1 to 4096 characters");
    const auto scan = methods::require_scan(s.store, id);
    if (!sample) {
      const auto catalogued = s.store.sample(scan.plan.sample_id);
      if (!catalogued || !catalogued->spec.bsdf)
        throw Error::invalid("sample", fmt::format("scan {}'s sample has no reference BSDF: give "
                                                   "the known sample's spec", id));
      sample = catalogued->spec.bsdf;
    }
    const auto data = methods::measured_of_scan(s.store, id);
    const auto profile = s.twin.profile();
    const auto result = methods::with_field("sample", [&] {
      return twin::calibrate(data, *sample, parameters, profile, options);
    });
    const auto stored = s.store.insert_fit(id, FitKind::calibrate, *sample, result.to_json(), actor(c));
    json out = methods::fit_json(stored);
    out["scan"] = id;
    auto reason = dry_run ? std::string("dry run") : not_applicable(result);
    if (reason.empty()) {
      const auto made = s.store.insert_profile(result.profile->name, json(*result.profile), id,
                                               stored.id, actor(c));
      s.twin.set_profile(*result.profile, made.version, made.created_at);
      spdlog::info("instrument calibrated by {} from scan {}: profile {} version {} ({})", actor(c),
                   id, made.name, made.version, fmt::join(parameters, ", "));
    } else {
      spdlog::info("calibration by {} from scan {} not applied: {}", actor(c), id, reason);
    }
    out["applied"] = reason.empty();
    if (!reason.empty()) out["reason"] = reason;
    out["profile"] = s.twin.profile_info();
    return out;
  });
}

}  // namespace gonio::daemon
