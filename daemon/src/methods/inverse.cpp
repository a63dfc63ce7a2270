// Shared by scan.fit and instrument.calibrate (see inverse.hpp).
#include "methods/inverse.hpp"

#include <fmt/format.h>

#include "methods/params.hpp"

namespace gonio::daemon::methods {

using nlohmann::json;

twin::MeasuredData measured_of_scan(const Store& store, std::int64_t id) {
  const auto scan = require_scan(store, id);
  if (scan.points_done == 0)
    throw Error::wrong_state("scan", fmt::format("scan {} has no measured points yet", id));
  json points = json::array();
  for (const auto& p : store.points(id, 0, scan.points_done + 1)) points.push_back(p);
  auto data = with_field("scan", [&] {
    return twin::measured_from_json(points, fmt::format("scan {}", id));
  });
  with_field("scan", [&] { data.validate(); });
  return data;
}

twin::FitOptions read_fit_options(json_util::ObjectReader& r, const TwinService& twin) {
  twin::FitOptions o;
  o.replicates = twin.options().replicates;
  o.seed = twin.options().seed;
  o.threads = twin.threads();
  o.samples = r.optional_in<std::uint64_t>("samples", 8192, 1024, std::uint64_t{1} << 22);
  o.max_iterations = r.optional_in<int>("max_iterations", o.max_iterations, 1, 1000);
  o.validate();
  return o;
}

Error renamed(const Error& e, const std::string& field) {
  std::string f = e.field(), msg = e.what();
  if (f.starts_with("bsdf")) {
    f = field + f.substr(4);
    if (msg.starts_with("bsdf")) msg = field + msg.substr(4);
  } else if (f.empty() || f == "measured") {
    f = field;
  } else if (f != field && !f.starts_with(field + ".") && !f.starts_with(field + "[")) {
    f = field + "." + f;
    msg = fmt::format("{}: {}", field, msg);
  }
  return Error(e.code(), msg, f);
}

json fit_json(const StoredFit& f) {
  return json{{"id", f.id},
              {"kind", to_text(f.kind)},
              {"model", f.model},
              {"created_by", f.created_by},
              {"created_at", f.created_at},
              {"result", f.result}};
}

}  // namespace gonio::daemon::methods
