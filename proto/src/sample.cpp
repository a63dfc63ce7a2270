// Sample catalog entries: validation and strict JSON (see sample.hpp).
#include "gonio/proto/sample.hpp"

#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio {

void SampleSpec::validate(std::string_view field) const {
  const auto f = [field](std::string_view k) { return join_field(field, k); };
  if (name.empty() || name.size() > kMaxNameLength)
    throw Error::invalid(f("name"), fmt::format("must have 1 to {} characters, got {}",
                                                kMaxNameLength, name.size()));
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '.' || c == '_' || c == '-';
    if (!ok)
      throw Error::invalid(f("name"), fmt::format("'{}' may only hold letters, digits, '.', '_' "
                                                  "and '-'",
                                                  name));
  }
  if (notes.size() > kMaxNotesLength)
    throw Error::invalid(f("notes"), fmt::format("has {} characters, more than the limit {}",
                                                 notes.size(), kMaxNotesLength));
  if (bsdf && (bsdf->empty() || bsdf->size() > kMaxBsdfLength))
    throw Error::invalid(f("bsdf"), fmt::format("must have 1 to {} characters (or be null for "
                                                "no predictions)",
                                                kMaxBsdfLength));
  if (!(tolerance >= 0 && tolerance <= kMaxTolerance))
    throw Error::out_of_range(f("tolerance"), tolerance, 0, kMaxTolerance);
  if (!(model_u >= 0 && model_u <= kMaxModelU))
    throw Error::out_of_range(f("model_u"), model_u, 0, kMaxModelU);
}

void to_json(nlohmann::json& j, const SampleSpec& s) {
  j = nlohmann::json{{"name", s.name},
                     {"notes", s.notes},
                     {"bsdf", s.bsdf ? nlohmann::json(*s.bsdf) : nlohmann::json(nullptr)},
                     {"tolerance", s.tolerance},
                     {"model_u", s.model_u}};
}

void from_json(const nlohmann::json& j, SampleSpec& s) {
  json_util::ObjectReader r(j, "");
  s.name = r.required<std::string>("name");
  s.notes = r.optional<std::string>("notes", "");
  const auto* bsdf = r.raw("bsdf");
  if (bsdf && !bsdf->is_null())
    s.bsdf = json_util::get_as<std::string>(*bsdf, "bsdf");
  else
    s.bsdf.reset();
  s.tolerance = r.optional<double>("tolerance", 0.02);
  s.model_u = r.optional<double>("model_u", 0.0);
  r.finish();
  s.validate("");
}

void to_json(nlohmann::json& j, const Sample& s) {
  to_json(j, s.spec);
  j["id"] = s.id;
  j["created_at"] = s.created_at;
  j["predicted"] = s.spec.bsdf.has_value();
  nlohmann::json cat = nlohmann::json(nullptr);
  if (!s.catalogue.empty()) {
    cat = nlohmann::json::parse(s.catalogue, nullptr, false);
    if (cat.is_object()) cat.erase("points");
    else cat = nlohmann::json(nullptr);
  }
  j["route"] = cat.is_object() ? cat.value("route", "formula") : "formula";
  j["catalogue"] = std::move(cat);
}

}  // namespace gonio
