// Alert JSON and severities (see alert.hpp).
#include "gonio/proto/alert.hpp"

#include <array>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio {
namespace {

template <typename T>
std::optional<T> read_opt(json_util::ObjectReader& r, const std::string& key) {
  const auto* v = r.raw(key);
  if (!v || v->is_null()) return std::nullopt;
  return json_util::get_as<T>(*v, key);
}

}  // namespace

void to_json(nlohmann::json& j, const Alert& a) {
  j = nlohmann::json{{"id", a.id},
                     {"kind", a.kind},
                     {"severity", to_text(a.severity)},
                     {"dedup_key", a.dedup_key},
                     {"scan_id", json_util::or_null(a.scan_id)},
                     {"sample_id", json_util::or_null(a.sample_id)},
                     {"point_index", json_util::or_null(a.point_index)},
                     {"message", a.message},
                     {"first_at", a.first_at},
                     {"last_at", a.last_at},
                     {"count", a.count},
                     {"acknowledged", a.acknowledged},
                     {"acknowledged_by", a.acknowledged_by},
                     {"acknowledged_at", json_util::or_null(a.acknowledged_at)},
                     {"resolved_at", json_util::or_null(a.resolved_at)},
                     {"resolution", json_util::or_null(a.resolution)}};
}

void from_json(const nlohmann::json& j, Alert& a) {
  json_util::ObjectReader r(j, "");
  a.id = r.required<std::int64_t>("id");
  a.kind = r.required<std::string>("kind");
  a.severity = parse_enum<Severity>(r.required<std::string>("severity"), "severity");
  a.dedup_key = r.optional<std::string>("dedup_key", "");
  a.scan_id = read_opt<std::int64_t>(r, "scan_id");
  a.sample_id = read_opt<std::int64_t>(r, "sample_id");
  a.point_index = read_opt<std::int64_t>(r, "point_index");
  a.message = r.required<std::string>("message");
  a.first_at = r.required<std::string>("first_at");
  a.last_at = r.optional<std::string>("last_at", a.first_at);
  a.count = r.optional<std::int64_t>("count", 1);
  a.acknowledged = r.optional<bool>("acknowledged", false);
  a.acknowledged_by = r.optional<std::string>("acknowledged_by", "");
  a.acknowledged_at = read_opt<std::string>(r, "acknowledged_at");
  a.resolved_at = read_opt<std::string>(r, "resolved_at");
  a.resolution = read_opt<std::string>(r, "resolution");
  r.finish();
}

}  // namespace gonio
