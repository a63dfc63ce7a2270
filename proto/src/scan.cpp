// Scan plans, scan records and UTC timestamps (see scan.hpp).
#include "gonio/proto/scan.hpp"

#include <array>
#include <cctype>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio {

// ---- UTC timestamps (RFC 3339 §5.6, UTC only) ----------------------------------------------

namespace utc {

std::string format(Clock::time_point t) {
  using namespace std::chrono;
  const auto ms = floor<milliseconds>(t);
  const auto day = floor<days>(ms);
  const year_month_day ymd{day};
  const hh_mm_ss hms{ms - day};
  return fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}.{:03}Z", static_cast<int>(ymd.year()),
                     static_cast<unsigned>(ymd.month()), static_cast<unsigned>(ymd.day()),
                     hms.hours().count(), hms.minutes().count(), hms.seconds().count(),
                     hms.subseconds().count());
}

std::string now() { return format(Clock::now()); }

Clock::time_point parse(std::string_view s, std::string_view field) {
  using namespace std::chrono;
  const auto fail = [&] {
    return Error::invalid(std::string(field),
                          fmt::format("'{}' is not a UTC time like 2025-01-31T12:00:00Z", s));
  };
  std::size_t pos = 0;
  const auto digits = [&](std::size_t n) {
    int v = 0;
    for (std::size_t i = 0; i < n; ++i, ++pos) {
      if (pos >= s.size() || !std::isdigit(static_cast<unsigned char>(s[pos]))) throw fail();
      v = v * 10 + (s[pos] - '0');
    }
    return v;
  };
  const auto expect = [&](char c) {
    if (pos >= s.size() || (s[pos] != c && !(c == 'T' && s[pos] == 't'))) throw fail();
    ++pos;
  };
  const int y = digits(4);
  expect('-');
  const int mo = digits(2);
  expect('-');
  const int d = digits(2);
  expect('T');
  const int h = digits(2);
  expect(':');
  const int mi = digits(2);
  expect(':');
  const int sec = digits(2);
  long long frac_ms = 0;
  if (pos < s.size() && s[pos] == '.') {
    ++pos;
    int n = 0;
    long long scale = 100;
    while (pos < s.size() && std::isdigit(static_cast<unsigned char>(s[pos]))) {
      if (n < 3) frac_ms += (s[pos] - '0') * scale, scale /= 10;
      ++pos, ++n;
    }
    if (n == 0) throw fail();
  }
  const auto rest = s.substr(pos);
  if (rest != "Z" && rest != "z" && rest != "+00:00") throw fail();
  const year_month_day ymd{year{y}, month{static_cast<unsigned>(mo)},
                           day{static_cast<unsigned>(d)}};
  if (!ymd.ok() || h > 23 || mi > 59 || sec > 60) throw fail();
  return sys_days{ymd} + hours{h} + minutes{mi} + seconds{sec} + milliseconds{frac_ms};
}

}  // namespace utc

// ---- plans -------------------------------------------------------------------------------

namespace {

// One entry of "geometries": a name ("45as15", "45/30"), the ASTM set ("astm") or an object.
void append_geometry(const nlohmann::json& item, const std::string& field,
                     std::vector<Geometry>& out) {
  if (item.is_string()) {
    const auto text = item.get<std::string>();
    if (text == "astm") {
      for (const auto& [name, g] : Geometry::astm_multi_angle()) out.push_back(g);
      return;
    }
    try {
      out.push_back(Geometry::parse(text));
    } catch (const Error& e) {
      // Geometry::parse names "geometry.*"; say which entry it was.
      throw Error(e.code(), fmt::format("{}: {}", field, e.what()), field);
    }
    return;
  }
  if (item.is_object()) {
    out.push_back(json_util::get_as<Geometry>(item, field));
    return;
  }
  throw Error::invalid(field, "expected \"45as15\", \"45/30\", \"astm\" or {\"theta_i\": .., "
                              "\"theta_r\": ..}, got " +
                                  json_util::type_name(item));
}

}  // namespace

bool ScanPlan::reads_reference(std::size_t since_start) const noexcept {
  switch (reference) {
    case ReferenceMode::every_point: return true;
    case ReferenceMode::start: return since_start == 0;
    case ReferenceMode::interval:
      return since_start % static_cast<std::size_t>(reference_interval) == 0;
  }
  return true;
}

void ScanPlan::validate(std::string_view field) const {
  const auto f = [field](std::string_view k) { return join_field(field, k); };
  if (sample_id < 0) throw Error::invalid(f("sample"), "must be a sample id or name");
  if (sample_id == 0 && sample_name.empty())
    throw Error::invalid(f("sample"), "is required (a sample id or name)");
  if (name.size() > 256)
    throw Error::invalid(f("name"), fmt::format("has {} characters, more than 256", name.size()));
  if (geometries.empty())
    throw Error::invalid(f("geometries"), "the plan has no geometry (give 'geometries' and/or "
                                          "'grids')");
  for (std::size_t i = 0; i < geometries.size(); ++i)
    geometries[i].validate(fmt::format("{}[{}]", f("geometries"), i));
  if (wavelengths.empty()) throw Error::invalid(f("wavelengths"), "needs at least one wavelength");
  if (repeats < 1 || repeats > kMaxRepeats)
    throw Error::out_of_range(f("repeats"), repeats, 1, kMaxRepeats);
  if (point_count() > kMaxPoints)
    throw Error(Errc::out_of_range,
                fmt::format("the plan has {} points ({} geometries × {} repeats), more than the "
                            "limit {}",
                            point_count(), geometries.size(), repeats, kMaxPoints),
                f("geometries"));
  if (reference_interval < 1 || reference_interval > kMaxReferenceInterval)
    throw Error::out_of_range(f("reference.interval"), reference_interval, 1,
                              kMaxReferenceInterval);
  if (priority < kMinPriority || priority > kMaxPriority)
    throw Error::out_of_range(f("priority"), priority, kMinPriority, kMaxPriority);
  if (not_before) (void)utc::parse(*not_before, f("not_before"));
  if (adaptive) {
    const auto& a = *adaptive;
    if (repeats != 1)
      throw Error::invalid(f("repeats"), "must be 1 in an adaptive scan (each candidate is measured "
                                         "at most once)");
    // Parameters mode may read a candidate up to three times (twin/design.md), curve mode once.
    const auto per = a.mode == AdaptiveMode::parameters ? 3 : 1;
    const auto candidates = static_cast<int>(std::min<std::size_t>(per * geometries.size(), kMaxPoints));
    if (a.max_points < 1 || a.max_points > candidates)
      throw Error::out_of_range(f("adaptive.max_points"), a.max_points, 1, candidates);
    if (a.mode == AdaptiveMode::parameters) {
      if (a.model.empty())
        throw Error::invalid(f("adaptive.model"), "is required in parameters mode (a BSDF spec "
                                                  "with '?' marks, e.g. \"conductor:alpha=?\")");
      if (!(a.target_rel_u > 0 && a.target_rel_u <= 1))
        throw Error::out_of_range(f("adaptive.target_rel_u"), a.target_rel_u, 0, 1);
    } else if (!(a.tolerance > 0 && a.tolerance <= 1)) {
      throw Error::out_of_range(f("adaptive.tolerance"), a.tolerance, 0, 1);
    }
  }
}

void to_json(nlohmann::json& j, const AdaptivePlan& a) {
  j = nlohmann::json{{"mode", to_text(a.mode)}, {"max_points", a.max_points}};
  if (a.mode == AdaptiveMode::parameters) {
    j["model"] = a.model;
    j["target_rel_u"] = a.target_rel_u;
  } else {
    j["tolerance"] = a.tolerance;
  }
}

namespace {

AdaptivePlan adaptive_from_json(const nlohmann::json& j) {
  if (!j.is_object()) throw Error::invalid("adaptive", "expected an object, got " + json_util::type_name(j));
  json_util::ObjectReader r(j, "adaptive");
  AdaptivePlan a;
  a.mode = parse_enum<AdaptiveMode>(r.required<std::string>("mode"), "adaptive.mode");
  a.max_points = r.required<int>("max_points");
  // The other mode's keys are left unread, so finish() names them.
  if (a.mode == AdaptiveMode::parameters) {
    a.model = r.required<std::string>("model");
    a.target_rel_u = r.required<double>("target_rel_u");
  } else {
    a.tolerance = r.required<double>("tolerance");
  }
  r.finish();
  return a;
}

}  // namespace

void to_json(nlohmann::json& j, const ScanPlan& p) {
  j = nlohmann::json{{"sample", p.sample_id},
                     {"name", p.name},
                     {"geometries", p.geometries},
                     {"wavelengths", p.wavelengths},
                     {"repeats", p.repeats},
                     {"reference", {{"mode", to_text(p.reference)},
                                    {"interval", p.reference_interval}}},
                     {"priority", p.priority},
                     {"not_before", p.not_before ? nlohmann::json(*p.not_before)
                                                 : nlohmann::json(nullptr)}};
  if (p.adaptive) j["adaptive"] = *p.adaptive;
}

void from_json(const nlohmann::json& j, ScanPlan& p) {
  json_util::ObjectReader r(j, "");
  p = ScanPlan{};
  const auto* sample = r.raw("sample");
  if (!sample) throw Error::invalid("sample", "is required (a sample id or name)");
  if (sample->is_number_integer()) {
    p.sample_id = sample->get<std::int64_t>();
    if (p.sample_id <= 0) throw Error::invalid("sample", "a sample id is a positive integer");
  } else if (sample->is_string()) {
    p.sample_name = sample->get<std::string>();
    if (p.sample_name.empty()) throw Error::invalid("sample", "is empty");
  } else {
    throw Error::invalid("sample", "expected a sample id or name, got " +
                                       json_util::type_name(*sample));
  }
  p.name = r.optional<std::string>("name", "");
  if (const auto* gs = r.raw("geometries"); gs && !gs->is_null()) {
    if (!gs->is_array()) throw Error::invalid("geometries", "expected an array");
    for (std::size_t i = 0; i < gs->size(); ++i) {
      append_geometry((*gs)[i], fmt::format("geometries[{}]", i), p.geometries);
      if (p.geometries.size() > ScanPlan::kMaxPoints)
        throw Error(Errc::out_of_range,
                    fmt::format("more than {} geometries", ScanPlan::kMaxPoints), "geometries");
    }
  }
  if (const auto* grids = r.raw("grids"); grids && !grids->is_null()) {
    nlohmann::json list = grids->is_string() ? nlohmann::json::array({*grids}) : *grids;
    if (!list.is_array()) throw Error::invalid("grids", "expected a grid string or an array");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const auto field = fmt::format("grids[{}]", i);
      const auto text = json_util::get_as<std::string>(list[i], field);
      try {
        const auto remaining = ScanPlan::kMaxPoints - std::min(ScanPlan::kMaxPoints,
                                                               p.geometries.size());
        for (const auto& g : parse_geometry_grid(text, std::max<std::size_t>(remaining, 1)))
          p.geometries.push_back(g);
      } catch (const Error& e) {
        throw json_util::prefixed(e, field);
      }
    }
  }
  p.wavelengths = r.optional<WavelengthGrid>("wavelengths", WavelengthGrid::visible());
  p.repeats = r.optional<int>("repeats", 1);
  if (const auto* ref = r.raw("reference"); ref && !ref->is_null()) {
    if (ref->is_string()) {
      p.reference = parse_enum<ReferenceMode>(ref->get<std::string>(), "reference");
    } else {
      json_util::ObjectReader rr(*ref, "reference");
      p.reference =
          parse_enum<ReferenceMode>(rr.optional<std::string>("mode", "every_point"), "reference.mode");
      p.reference_interval = rr.optional<int>("interval", 10);
      rr.finish();
    }
  }
  p.priority = r.optional<int>("priority", 0);
  if (const auto* nb = r.raw("not_before"); nb && !nb->is_null())
    p.not_before = json_util::get_as<std::string>(*nb, "not_before");
  if (const auto* a = r.raw("adaptive"); a && !a->is_null()) p.adaptive = adaptive_from_json(*a);
  r.finish();
  p.validate("");
}

// ---- scans -------------------------------------------------------------------------------

nlohmann::json to_json(const Scan& s, bool with_geometries) {
  nlohmann::json plan = s.plan;
  if (!with_geometries) {
    plan.erase("geometries");
    plan["geometry_count"] = s.plan.geometries.size();
  }
  return nlohmann::json{{"id", s.id},
                        {"plan", std::move(plan)},
                        {"state", to_text(s.state)},
                        {"reason", s.reason},
                        {"predicted", s.predicted},
                        {"submitted_by", s.submitted_by},
                        {"submitted_at", s.submitted_at},
                        {"started_at", json_util::or_null(s.started_at)},
                        {"finished_at", json_util::or_null(s.finished_at)},
                        {"points_total", s.points_total},
                        {"points_done", s.points_done},
                        {"points_diverged", s.points_diverged},
                        {"queue_position", s.queue_position}};
}

void to_json(nlohmann::json& j, const Scan& s) { j = to_json(s, true); }

}  // namespace gonio
