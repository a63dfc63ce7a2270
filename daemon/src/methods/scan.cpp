// The scan.* methods: submitting, reading, controlling, paging and exporting scans.
#include <iterator>
#include <string>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/instrument/adaptive_loop.hpp"
#include "gonio/daemon/instrument/catalogue.hpp"
#include "gonio/daemon/store/export.hpp"
#include "methods/inverse.hpp"
#include "methods/params.hpp"
#include "methods/registrar.hpp"

namespace gonio::daemon {

using json_util::ObjectReader;
using methods::actor;
using methods::kMaxPage;
using methods::read_count;
using methods::read_id;
using methods::read_offset;
using methods::require_scan;
using methods::resolve_sample;
using methods::scan_summary;
using nlohmann::json;

namespace {

// The most values (points × wavelength channels) one scan.export call reads and writes: a
// csv or json chunk (~160–200 bytes of text per value, ~3 MB: two copies of it are what a
// worker holds while it writes one, a term of the memory bound in daemon/README.md), and a
// bsdf or ssdd table, which needs the whole scan at once.
constexpr std::size_t kMaxChunkValues = 16384;
constexpr std::size_t kMaxTableValues = 262144;
// Room left after an answer written as text for the JSON-RPC envelope around it (its head,
// the id and the closing brace; an id longer than that costs one copy).
constexpr std::size_t kEnvelopeRoom = 128;

enum class Control { pause, resume, cancel };

// A scan whose points retention pruned (store.retention_days) answers for them with
// not_found saying so: an empty page would read as a scan that measured nothing.
void refuse_pruned(const Store& store, std::int64_t id) {
  if (const auto at = store.points_pruned_at(id))
    throw Error(Errc::not_found,
                fmt::format("scan {}'s points were pruned at {} (store.retention_days), after the central archive "
                            "had committed every one of them: read them from the archive",
                            id, *at),
                "scan");
}

// scan.pause, scan.resume and scan.cancel: {scan, reason?} -> the scan's summary.
rpc::Handler control(Services& s, Control what) {
  return [&s, what](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto id = read_id(r, "scan");
    const auto reason = r.optional<std::string>("reason", "");
    r.finish();
    if (reason.size() > 512) throw Error::invalid("reason", "has more than 512 characters");
    const Scan sc = what == Control::pause    ? s.instrument.pause(id, actor(c), reason)
                    : what == Control::resume ? s.instrument.resume(id, actor(c))
                                              : s.instrument.cancel(id, actor(c), reason);
    return scan_summary(sc);
  };
}

rpc::Result scan_submit(Services& s, rpc::Call& c) {
  auto plan = c.params.get<ScanPlan>();
  const auto sample = plan.sample_id ? resolve_sample(s.store, json(plan.sample_id), "sample")
                                     : resolve_sample(s.store, json(plan.sample_name), "sample");
  plan.sample_id = sample.id;
  plan.sample_name.clear();
  s.instrument.validate_plan(plan);
  AdaptiveLoop::check(plan);
  // A master predicts only where it was measured: refused here, not point by point later.
  if (!sample.catalogue.empty()) {
    const auto cat = Catalogue::of(sample);
    for (std::size_t i = 0; i < plan.geometries.size(); ++i)
      if (const auto why = cat.uncovered(plan.geometries[i]); !why.empty())
        throw Error(Errc::plan_rejected,
                    fmt::format("geometries[{}] = {}: sample '{}': {}", i, plan.geometries[i].to_string(),
                                sample.spec.name, why),
                    fmt::format("geometries[{}]", i));
  }
  bool predicted = sample.spec.bsdf.has_value();
  if (predicted) (void)s.twin.make(*sample.spec.bsdf, plan.wavelengths, "sample.bsdf");
  const auto scan = s.store.insert_scan(plan, predicted, actor(c));
  spdlog::info("scan {} submitted by {}: sample '{}', {} points, priority {}", scan.id, actor(c),
               sample.spec.name, scan.points_total, plan.priority);
  s.hub.publish(Topic::state, "scan.state",
                json{{"scan", scan.id}, {"state", "queued"}, {"reason", ""}}, scan.id);
  s.instrument.wake();
  json out = scan_summary(scan);
  if (!predicted) out["note"] = "the sample has no reference BSDF: measured without predictions";
  return out;
}

rpc::Result scan_get(Services& s, rpc::Call& c) {
  ObjectReader r(c.params, "");
  const auto id = read_id(r, "scan");
  const auto geometries = r.optional<bool>("geometries", false);
  r.finish();
  json out = to_json(require_scan(s.store, id), geometries);
  json fits = json::array();
  for (const auto& f : s.store.fits(id, methods::kFitsShown)) fits.push_back(methods::fit_json(f));
  out["fits"] = std::move(fits);
  const auto verdict = s.store.latest_fit(id, FitKind::verdict);
  out["verdict"] = verdict ? verdict->result : json(nullptr);
  const auto pruned = s.store.points_pruned_at(id);
  out["points_pruned_at"] = pruned ? json(*pruned) : json(nullptr);
  // An adaptive scan's loop: live while it runs, else as stored when it last stopped.
  if (out["plan"].contains("adaptive")) {
    if (auto live = s.instrument.adaptive_status(id)) out["adaptive"] = std::move(*live);
    else if (const auto last = s.store.latest_fit(id, FitKind::adaptive)) out["adaptive"] = last->result;
    else out["adaptive"] = json(nullptr);
  }
  return out;
}

rpc::Result scan_list(Services& s, rpc::Call& c) {
  ObjectReader r(c.params, "");
  ScanFilter f;
  if (const auto* st = r.raw("state"); st && !st->is_null())
    f.state = parse_enum<ScanState>(json_util::get_as<std::string>(*st, "state"), "state");
  if (const auto* sm = r.raw("sample"); sm && !sm->is_null())
    f.sample_id = resolve_sample(s.store, *sm, "sample").id;
  // Times are normalised as the store writes them, so that comparing the text compares times.
  for (auto [key, to] : {std::pair{"since", &f.since}, std::pair{"until", &f.until}})
    if (const auto* t = r.raw(key); t && !t->is_null())
      *to = utc::format(utc::parse(json_util::get_as<std::string>(*t, key), key));
  if (f.since && f.until && *f.until <= *f.since)
    throw Error::invalid("until", fmt::format("{} is not after since ({})", *f.until, *f.since));
  if (const auto* t = r.raw("text"); t && !t->is_null()) {
    auto text = json_util::get_as<std::string>(*t, "text");
    if (text.size() > 200) throw Error::invalid("text", "is longer than 200 characters");
    if (!text.empty()) f.text = std::move(text);
  }
  f.offset = read_offset(r);
  f.limit = read_count(r, "limit", 100, kMaxPage);
  r.finish();
  json out = json::array();
  for (const auto& x : s.store.scans(f)) out.push_back(scan_summary(x));
  return out;
}

rpc::Result scan_points(Services& s, rpc::Call& c) {
  ObjectReader r(c.params, "");
  const auto id = read_id(r, "scan");
  const auto offset = read_offset(r);
  const auto limit = read_count(r, "limit", 100, kMaxPage);
  r.finish();
  // Served from the stored JSON text as it is: no parse, no print (scan.points is what
  // clients poll).
  const auto progress = s.store.scan_progress(id);
  if (!progress) throw Error::not_found("scan", fmt::format("scan {}", id));
  const auto texts = s.store.point_json(id, offset, limit);
  if (texts.empty() && offset < progress->first) refuse_pruned(s.store, id);
  const auto next = offset + texts.size();
  std::string out = fmt::format(R"({{"scan":{},"offset":{},"points_done":{},"points_total":{},"next_offset":{},"points":[)",
                                id, offset, progress->first, progress->second,
                                next < progress->first ? std::to_string(next) : "null");
  std::size_t bytes = out.size() + 2;
  for (const auto& t : texts) bytes += t.size() + 1;
  out.reserve(bytes);  // a page of 1000 points is megabytes: built once, not regrown
  for (std::size_t i = 0; i < texts.size(); ++i) {
    if (i) out += ',';
    out += texts[i];
  }
  out += "]}";
  return rpc::RawJson{std::move(out)};
}

rpc::Result scan_export(Services& s, rpc::Call& c) {
  ObjectReader r(c.params, "");
  const auto id = read_id(r, "scan");
  const auto format = r.optional<std::string>("format", "csv");
  if (format != "csv" && format != "json" && format != "bsdf" && format != "ssdd")
    throw Error::invalid("format", fmt::format("'{}' is not an export format (allowed: csv, "
                                               "json, bsdf, ssdd)",
                                               format));
  const auto scan = require_scan(s.store, id);
  refuse_pruned(s.store, id);
  const std::size_t channels = std::max<std::size_t>(1, scan.plan.wavelengths.size());
  const bool table = format == "bsdf" || format == "ssdd";
  std::size_t offset = 0, limit = 0;
  if (table) {
    if (r.has("offset") || r.has("limit"))
      throw Error::invalid(r.has("offset") ? "offset" : "limit",
                           fmt::format("a {} export is one table of the whole scan: it takes no "
                                       "offset or limit",
                                       format));
    if (scan.points_done * channels > kMaxTableValues)
      throw Error(Errc::unsupported,
                  fmt::format("scan {} has {} points × {} channels = {} values, more than one {} "
                              "table carries ({}); export csv or json, in chunks",
                              id, scan.points_done, channels, scan.points_done * channels, format,
                              kMaxTableValues),
                  "scan");
    limit = scan.points_done;
  } else {
    // A chunk holds at most kMaxChunkValues values: the points of larger scans come in
    // several calls, each starting at the previous one's next_offset.
    const std::size_t per_chunk = std::max<std::size_t>(1, kMaxChunkValues / channels);
    offset = read_offset(r);
    limit = read_count(r, "limit", per_chunk, per_chunk);
  }
  r.finish();
  // A chunk's answer is megabytes and many clients may export at once: the points go once
  // the content is written, the content once it is escaped, and the answer has room for its
  // envelope, so that it is wrapped where it lies (response_text). At most two copies of the
  // content are in memory at a time.
  ExportResult e;
  std::size_t end = offset;
  bool last = table;
  {
    const auto points = s.store.points(id, offset, limit);
    end = offset + points.size();
    last = table || end >= scan.points_done;
    e = table ? export_scan(scan, points, format) : export_chunk(scan, points, format, offset, last);
  }
  const std::string content = json(std::move(e.content)).dump();
  std::string out = json{{"scan", id}, {"format", e.format}, {"filename", e.filename},
                         {"media_type", e.media_type}, {"offset", offset}, {"points", end - offset},
                         {"points_done", scan.points_done},
                         {"next_offset", last ? json(nullptr) : json(end)}}
                        .dump();
  out.pop_back();
  constexpr std::string_view kContent = R"(,"content":)";
  out.reserve(out.size() + kContent.size() + content.size() + 1 + kEnvelopeRoom);
  out += kContent;
  out += content;
  out += '}';
  return rpc::RawJson{std::move(out)};
}

// The inverse twin on a stored scan: the model's free parameters fitted through the twin
// of the current instrument profile; the result is stored with the scan.
rpc::Result scan_fit(Services& s, rpc::Call& c) {
  ObjectReader r(c.params, "");
  const auto id = read_id(r, "scan");
  const auto model = methods::confine_bsdf_files(r.required<std::string>("model"), s.data_dir, "model");
  auto options = methods::read_fit_options(r, s.twin);
  r.finish();
  if (model.empty() || model.size() > 4096)
    throw Error::invalid("model", "give a BSDF spec of 1 to 4096 characters with '?' marks");
  const auto data = methods::measured_of_scan(s.store, id);
  // The template alone first: a bad spec is refused before any twin work.
  (void)methods::with_field("model", [&] { return twin::ModelTemplate(model, data.wavelengths); });
  const auto profile = s.twin.profile();
  const auto result = methods::with_field(
      "model", [&] { return twin::fit_material(data, model, profile, options); });
  const auto stored = s.store.insert_fit(id, FitKind::fit, model, result.to_json(), actor(c));
  spdlog::info("scan {} fitted by {}: '{}' -> '{}', chi2/dof {:.3g}, {} evaluations, {:.1f} s",
               id, actor(c), model, result.spec, result.chi2_per_dof, result.evaluations,
               result.seconds);
  json out = methods::fit_json(stored);
  out["scan"] = id;
  return out;
}

}  // namespace

void register_scan(MethodRegistrar& reg, Services& s) {
  reg.add("scan.submit", [&s](rpc::Call& c) { return scan_submit(s, c); });
  reg.add("scan.get", [&s](rpc::Call& c) { return scan_get(s, c); });
  reg.add("scan.list", [&s](rpc::Call& c) { return scan_list(s, c); });
  reg.add("scan.points", [&s](rpc::Call& c) { return scan_points(s, c); });
  reg.add("scan.export", [&s](rpc::Call& c) { return scan_export(s, c); });
  reg.add("scan.fit", [&s](rpc::Call& c) { return scan_fit(s, c); });
  reg.add("scan.pause", control(s, Control::pause));
  reg.add("scan.resume", control(s, Control::resume));
  reg.add("scan.cancel", control(s, Control::cancel));
}

}  // namespace gonio::daemon
