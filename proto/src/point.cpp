// PointRecord JSON (see point.hpp).
#include "gonio/proto/point.hpp"

#include <algorithm>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio {

namespace {

// One value for every channel is written as a number.
nlohmann::json compact(const std::vector<double>& v) {
  if (!v.empty() && std::all_of(v.begin(), v.end(), [&](double x) { return x == v.front(); }))
    return v.front();
  return v;
}

std::vector<double> read_vector(const nlohmann::json& j, const std::string& field) {
  if (j.is_number()) return {json_util::get_as<double>(j, field)};
  return json_util::get_as<std::vector<double>>(j, field);
}

}  // namespace

void to_json(nlohmann::json& j, const BudgetEntry& b) {
  j = nlohmann::json{{"component", b.component},       {"distribution", b.distribution},
                     {"unit", b.unit},                 {"random", b.random},
                     {"u", compact(b.u)},              {"sensitivity", b.sensitivity},
                     {"contribution", b.contribution}};
  if (!b.curvature.empty()) j["curvature"] = b.curvature;
  if (!b.cross.empty()) j["cross"] = nlohmann::json{{"with", b.cross_with}, {"values", b.cross}};
}

void from_json(const nlohmann::json& j, BudgetEntry& b) {
  json_util::ObjectReader r(j, "budget[]");
  b.component = r.required<std::string>("component");
  b.distribution = r.required<std::string>("distribution");
  b.unit = r.optional<std::string>("unit", "");
  b.random = r.optional<bool>("random", false);
  const auto* u = r.raw("u");
  if (!u) throw Error::invalid(r.path("u"), "is required");
  b.u = read_vector(*u, r.path("u"));
  b.sensitivity = r.required<std::vector<double>>("sensitivity");
  b.contribution = r.required<std::vector<double>>("contribution");
  b.curvature = r.optional<std::vector<double>>("curvature", {});
  if (const auto* x = r.raw("cross"); x && !x->is_null()) {
    json_util::ObjectReader xr(*x, r.path("cross"));
    b.cross_with = xr.required<std::string>("with");
    b.cross = xr.required<std::vector<double>>("values");
    xr.finish();
  }
  r.finish();
}

void to_json(nlohmann::json& j, const SampleSensitivity& s) {
  j = nlohmann::json{{"parameter", s.parameter}, {"value", s.value}, {"sensitivity", s.sensitivity}};
}

void from_json(const nlohmann::json& j, SampleSensitivity& s) {
  json_util::ObjectReader r(j, "sample_sensitivity[]");
  s.parameter = r.required<std::string>("parameter");
  s.value = r.required<double>("value");
  s.sensitivity = r.required<std::vector<double>>("sensitivity");
  r.finish();
}

void to_json(nlohmann::json& j, const ColorCheck& c) {
  j = nlohmann::json{{"kind", c.kind},   {"difference", c.difference}, {"u", c.u},
                     {"limit", c.limit}, {"decision", c.decision}};
  if (c.luminance_ratio) j["luminance_ratio"] = *c.luminance_ratio;
  if (c.luminance_u) j["luminance_u"] = *c.luminance_u;
}

void from_json(const nlohmann::json& j, ColorCheck& c) {
  json_util::ObjectReader r(j, "colour");
  c.kind = r.required<std::string>("kind");
  c.difference = r.required<double>("difference");
  c.u = r.required<double>("u");
  c.limit = r.required<double>("limit");
  c.decision = r.required<std::string>("decision");
  c.luminance_ratio.reset();
  c.luminance_u.reset();
  if (r.has("luminance_ratio")) c.luminance_ratio = r.required<double>("luminance_ratio");
  if (r.has("luminance_u")) c.luminance_u = r.required<double>("luminance_u");
  r.finish();
}

void to_json(nlohmann::json& j, const PointRecord& p) {
  j = nlohmann::json{{"scan_id", p.scan_id},
                     {"index", p.index},
                     {"geometry_index", p.geometry_index},
                     {"repeat", p.repeat},
                     {"planned", p.planned},
                     {"actual", p.actual},
                     {"started_at", p.started_at},
                     {"finished_at", p.finished_at},
                     {"measured", p.measured},
                     {"predicted", json_util::or_null(p.predicted)},
                     {"twin_version", p.twin_version},
                     {"z_max", json_util::or_null(p.z_max)},
                     {"delta_e00", json_util::or_null(p.delta_e00)},
                     {"diverged", p.diverged},
                     {"flags", p.flags}};
  // Absent on points measured without a prediction (and on points stored before them).
  if (!p.decision.empty()) j["decision"] = p.decision;
  if (!p.u_model.empty()) j["u_model"] = p.u_model;
  if (!p.budget.empty()) j["budget"] = p.budget;
  if (!p.sample_sensitivity.empty()) j["sample_sensitivity"] = p.sample_sensitivity;
  if (p.color) j["colour"] = *p.color;
  if (p.integration_ms) j["integration_ms"] = *p.integration_ms;
}

void from_json(const nlohmann::json& j, PointRecord& p) {
  json_util::ObjectReader r(j, "");
  p.scan_id = r.required<std::int64_t>("scan_id");
  p.index = r.required<std::int64_t>("index");
  p.geometry_index = r.required<std::int64_t>("geometry_index");
  p.repeat = r.required<int>("repeat");
  p.planned = r.required<Geometry>("planned");
  // Read back positions may sit a hair outside the nominal ranges; do not re-validate.
  const auto* actual = r.raw("actual");
  if (!actual) throw Error::invalid("actual", "is required");
  json_util::ObjectReader ra(*actual, "actual");
  p.actual.theta_i = ra.required<double>("theta_i");
  p.actual.theta_r = ra.required<double>("theta_r");
  p.actual.phi_i = ra.optional<double>("phi_i", 0.0);
  p.actual.phi_r = ra.optional<double>("phi_r", 0.0);
  ra.finish();
  p.started_at = r.required<std::string>("started_at");
  p.finished_at = r.required<std::string>("finished_at");
  p.measured = r.required<Spectrum>("measured");
  p.predicted.reset();
  if (const auto* pred = r.raw("predicted"); pred && !pred->is_null())
    p.predicted = json_util::get_as<Spectrum>(*pred, "predicted");
  p.twin_version = r.optional<std::string>("twin_version", "");
  p.z_max.reset();
  if (const auto* z = r.raw("z_max"); z && !z->is_null()) p.z_max = json_util::get_as<double>(*z, "z_max");
  p.delta_e00.reset();
  if (const auto* d = r.raw("delta_e00"); d && !d->is_null())
    p.delta_e00 = json_util::get_as<double>(*d, "delta_e00");
  p.diverged = r.optional<bool>("diverged", false);
  p.flags = r.optional<std::vector<std::string>>("flags", {});
  p.decision = r.optional<std::string>("decision", "");
  if (!p.decision.empty() && p.decision != "agrees" && p.decision != "out_of_tolerance" &&
      p.decision != "undecided")
    throw Error::invalid("decision", fmt::format("'{}' (allowed: agrees, out_of_tolerance, undecided)", p.decision));
  p.u_model = r.optional<std::vector<double>>("u_model", {});
  p.budget = r.optional<std::vector<BudgetEntry>>("budget", {});
  p.sample_sensitivity = r.optional<std::vector<SampleSensitivity>>("sample_sensitivity", {});
  p.color.reset();
  if (const auto* c = r.raw("colour"); c && !c->is_null()) p.color = c->get<ColorCheck>();
  p.integration_ms.reset();
  if (const auto* t = r.raw("integration_ms"); t && !t->is_null()) {
    p.integration_ms = json_util::get_as<double>(*t, "integration_ms");
    if (!(*p.integration_ms > 0)) throw Error::invalid("integration_ms", "must be > 0");
  }
  r.finish();
  if (p.index < 0) throw Error::invalid("index", "must be >= 0");
}

}  // namespace gonio
