// PointRecord JSON (see point.hpp).
#include "gonio/proto/point.hpp"

#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio {

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
  r.finish();
  if (p.index < 0) throw Error::invalid("index", "must be >= 0");
}

}  // namespace gonio
