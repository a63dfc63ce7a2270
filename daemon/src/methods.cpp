// goniod's JSON-RPC methods: parameter checking, roles, and calls into the services.
#include "gonio/daemon/methods.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <charconv>
#include <chrono>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/export.hpp"
#include "gonio/drivers/motion/motion_controller.hpp"
#include "gonio/proto/json_util.hpp"
#include "gonio/proto/text.hpp"

#ifndef GONIO_VERSION
#define GONIO_VERSION "0.0.0"
#endif

namespace gonio::daemon {

using json_util::ObjectReader;
using nlohmann::json;

namespace {

constexpr std::size_t kMaxPage = 1000;
constexpr std::size_t kMaxPredict = 1000;
constexpr std::size_t kMaxExportPoints = 200000;

std::int64_t read_id(ObjectReader& r, const std::string& key) {
  const auto v = r.required<std::int64_t>(key);
  if (v <= 0) throw Error::invalid(r.path(key), fmt::format("{} is not an id (ids are >= 1)", v));
  return v;
}

std::size_t read_count(ObjectReader& r, const std::string& key, std::size_t fallback,
                       std::size_t max) {
  const auto v = r.optional<long long>(key, static_cast<long long>(fallback));
  if (v < 0 || static_cast<unsigned long long>(v) > max)
    throw Error::out_of_range(r.path(key), static_cast<double>(v), 0, static_cast<double>(max));
  return static_cast<std::size_t>(v);
}

std::size_t read_offset(ObjectReader& r) {
  return read_count(r, "offset", 0, static_cast<std::size_t>(1) << 40);
}

// "sample": an id or a name.
Sample resolve_sample(const Store& store, const json& ref, const std::string& field) {
  std::optional<Sample> s;
  if (ref.is_number_integer()) {
    const auto id = ref.get<std::int64_t>();
    s = store.sample(id);
    if (!s) throw Error(Errc::not_found, fmt::format("{}: sample {} does not exist", field, id), field);
  } else if (ref.is_string()) {
    const auto name = ref.get<std::string>();
    s = store.sample_by_name(name);
    if (!s)
      throw Error(Errc::not_found, fmt::format("{}: sample '{}' does not exist", field, name), field);
  } else {
    throw Error::invalid(field, "expected a sample id or name, got " + json_util::type_name(ref));
  }
  return *s;
}

Scan require_scan(const Store& store, std::int64_t id) {
  auto s = store.scan(id);
  if (!s) throw Error(Errc::not_found, fmt::format("scan: scan {} does not exist", id), "scan");
  return *s;
}

std::string actor(const rpc::Call& c) { return c.principal.name; }

json principal_json(const Principal& p) {
  return json{{"name", p.name}, {"role", role_name(p.role)}, {"transport", p.transport}};
}

json scan_summary(const Scan& s) { return to_json(s, false); }

std::map<drivers::Axis, double> read_targets(ObjectReader& r) {
  std::map<drivers::Axis, double> t;
  for (auto a : drivers::kAllAxes) {
    const std::string key(drivers::axis_name(a));
    if (r.has(key)) t[a] = r.required<double>(key);
  }
  return t;
}

// resident_bytes() for system.info, read at most every 100 ms: under polling, the read of
// /proc was a third of the method's system calls.
std::size_t sampled_resident_bytes() {
  static std::atomic<std::chrono::steady_clock::rep> next{0};
  static std::atomic<std::size_t> value{0};
  const auto now = std::chrono::steady_clock::now();
  if (now.time_since_epoch().count() < next.load(std::memory_order_acquire))
    return value.load(std::memory_order_relaxed);
  const auto v = resident_bytes();
  value.store(v, std::memory_order_relaxed);
  next.store((now + std::chrono::milliseconds(100)).time_since_epoch().count(), std::memory_order_release);
  return v;
}

}  // namespace

std::size_t resident_bytes() {
  // Kept open: a pread from offset 0 regenerates the file, one system call instead of a path
  // lookup, an open, a stream and a close on every system.info.
  static const int fd = ::open("/proc/self/statm", O_RDONLY | O_CLOEXEC);
  static const auto page = static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
  if (fd < 0) return 0;
  char buf[128];
  const auto n = ::pread(fd, buf, sizeof buf, 0);
  if (n <= 0) return 0;
  // "size resident shared text lib data dt"
  const char* p = buf;
  const char* const end = buf + n;
  std::size_t fields[2] = {0, 0};
  for (auto& f : fields) {
    while (p < end && *p == ' ') ++p;
    const auto [next, ec] = std::from_chars(p, end, f);
    if (ec != std::errc()) return 0;
    p = next;
  }
  return fields[1] * page;
}

void register_methods(rpc::Dispatcher& d, Services& s) {
  const auto add = [&d](std::string name, Role role, bool blocking, rpc::Handler h) {
    d.add(rpc::Method{std::move(name), role, blocking, std::move(h)});
  };

  // ---- rpc / auth ------------------------------------------------------------------------
  add("rpc.discover", Role::none, false, [](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    return openrpc_document();
  });

  add("auth.login", Role::none, false, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto token = r.required<std::string>("token");
    r.finish();
    auto p = s.auth.authenticate(token, c.session->transport());
    if (!p) {
      spdlog::warn("auth.login refused on {} from {}", c.session->transport(), c.session->peer());
      throw Error(Errc::unauthorized, "token: unknown token", "token");
    }
    c.session->set_principal(*p);
    spdlog::info("{} logged in as {} on {} from {}", p->name, role_name(p->role),
                 c.session->transport(), c.session->peer());
    return principal_json(*p);
  });

  add("auth.whoami", Role::viewer, false, [](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    return principal_json(c.principal);
  });

  add("auth.create_token", Role::admin, false, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto name = r.required<std::string>("name");
    const auto role = parse_role(r.required<std::string>("role"), "role");
    r.finish();
    if (name.empty() || name.size() > 64 || name.find_first_of(" \t\n:") != std::string::npos)
      throw Error::invalid("name", "must have 1 to 64 characters, without spaces or ':'");
    const auto token = s.auth.create(name, role);
    s.store.audit(actor(c), "auth.create_token", fmt::format("token:{}", name),
                  json{{"role", role_name(role)}});
    return json{{"name", name}, {"role", role_name(role)}, {"token", token}};
  });

  add("auth.list_tokens", Role::admin, false, [&s](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    json out = json::array();
    for (const auto& t : s.auth.list()) out.push_back(json{{"name", t.name}, {"role", role_name(t.role)}});
    return out;
  });

  add("auth.revoke_token", Role::admin, false, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto name = r.required<std::string>("name");
    r.finish();
    if (!s.auth.revoke(name))
      throw Error(Errc::not_found, fmt::format("name: no stored token named '{}'", name), "name");
    s.store.audit(actor(c), "auth.revoke_token", fmt::format("token:{}", name));
    return json{{"revoked", name}};
  });

  // ---- system ----------------------------------------------------------------------------
  // system.info is what monitors poll: the members fixed at start are serialised once, the
  // others are written straight to text (no JSON tree per call). Members come in no
  // particular order.
  const auto fixed = [&s] {
    std::string t = json{{"name", "goniod"},
                         {"version", GONIO_VERSION},
                         {"api_version", openrpc_document()["info"]["version"]},
                         {"schema_version", Store::kSchemaVersion},
                         {"started_at", s.started_at},
                         {"state_dir", s.state_dir.string()},
                         {"divergence", {{"z_threshold", s.config.z_threshold},
                                         {"delta_e_threshold", s.config.delta_e_threshold},
                                         {"sustained_m", s.config.sustained_m},
                                         {"sustained_n", s.config.sustained_n},
                                         {"reference_drift", s.config.reference_drift}}}}
                        .dump();
    t.back() = ',';  // the closing brace comes after the live members
    return t;
  }();
  const auto twin_fixed =
      fmt::format(R"("version":{},"threads":{})", json(s.twin.version()).dump(), s.twin.threads());
  add("system.info", Role::viewer, false, [&s, fixed, twin_fixed](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    const auto uptime = std::chrono::duration<double>(std::chrono::steady_clock::now() - s.started).count();
    const auto running = s.instrument.running_scan();
    std::string out;
    out.reserve(fixed.size() + 1024);
    out += fixed;
    fmt::format_to(std::back_inserter(out),
                   R"("uptime_s":{},"running_scan":{},"rss_bytes":{},"rpc":{{"requests":{},"errors":{}}},)"
                   R"("subscribers":{},"notifications_dropped":{},"runner":{},)"
                   R"("twin":{{{},"queued":{}}},"you":{})",
                   uptime, running ? std::to_string(*running) : "null", sampled_resident_bytes(),
                   s.dispatcher ? s.dispatcher->requests() : 0, s.dispatcher ? s.dispatcher->errors() : 0,
                   s.hub.sessions(), s.hub.dropped(), s.instrument.stats().dump(), twin_fixed,
                   s.twin.queued(), principal_json(c.principal).dump());
    if (auto sink = s.alerts.sink()) (out += R"(,"webhook":)") += sink->stats().dump();
    if (s.transport_stats) (out += R"(,"transport":)") += s.transport_stats().dump();
    out += '}';
    return rpc::RawJson{std::move(out)};
  });

  add("system.audit", Role::admin, false, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto offset = read_offset(r);
    const auto limit = read_count(r, "limit", 100, kMaxPage);
    r.finish();
    json out = json::array();
    for (const auto& e : s.store.audit_events(offset, limit))
      out.push_back(json{{"id", e.id}, {"at", e.at}, {"actor", e.actor}, {"action", e.action},
                         {"target", e.target}, {"detail", e.detail}});
    return out;
  });

  // ---- instrument ------------------------------------------------------------------------
  add("instrument.status", Role::viewer, false, [&s](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    return s.instrument.status();
  });

  add("instrument.home", Role::technician, true, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    std::vector<drivers::Axis> axes;
    if (const auto* a = r.raw("axes"); a && !a->is_null()) {
      if (!a->is_array()) throw Error::invalid("axes", "expected an array of axis names");
      for (std::size_t i = 0; i < a->size(); ++i) {
        const auto field = fmt::format("axes[{}]", i);
        axes.push_back(drivers::parse_axis(field, json_util::get_as<std::string>((*a)[i], field)));
      }
    }
    r.finish();
    return s.instrument.home(axes, actor(c));
  });

  add("instrument.move", Role::technician, true, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto targets = read_targets(r);
    r.finish();
    if (targets.empty())
      throw Error::invalid("params", "give at least one of incidence, receive, rotation, tilt "
                                     "(degrees)");
    for (const auto& [axis, deg] : targets)
      if (!std::isfinite(deg))
        throw Error::invalid(std::string(drivers::axis_name(axis)), "must be a finite number");
    return s.instrument.move(targets, actor(c));
  });

  add("instrument.stop", Role::technician, false, [&s](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    return s.instrument.stop(actor(c));
  });

  add("instrument.reset", Role::technician, true, [&s](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    return s.instrument.reset(actor(c));
  });

  // ---- samples ---------------------------------------------------------------------------
  add("sample.create", Role::technician, true, [&s](rpc::Call& c) {
    const auto spec = c.params.get<SampleSpec>();
    if (spec.bsdf) (void)s.twin.make(*spec.bsdf, WavelengthGrid::visible(), "bsdf");
    return json(s.store.create_sample(spec, actor(c)));
  });

  add("sample.get", Role::viewer, false, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto* ref = r.raw("sample");
    r.finish();
    if (!ref) throw Error::invalid("sample", "is required (a sample id or name)");
    return json(resolve_sample(s.store, *ref, "sample"));
  });

  add("sample.list", Role::viewer, false, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto offset = read_offset(r);
    const auto limit = read_count(r, "limit", 100, kMaxPage);
    r.finish();
    json out = json::array();
    for (const auto& x : s.store.samples(offset, limit)) out.push_back(x);
    return out;
  });

  // ---- scans -----------------------------------------------------------------------------
  add("scan.submit", Role::technician, true, [&s](rpc::Call& c) {
    auto plan = c.params.get<ScanPlan>();
    const auto sample = plan.sample_id ? resolve_sample(s.store, json(plan.sample_id), "sample")
                                       : resolve_sample(s.store, json(plan.sample_name), "sample");
    plan.sample_id = sample.id;
    plan.sample_name.clear();
    s.instrument.validate_plan(plan);
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
  });

  add("scan.get", Role::viewer, false, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto id = read_id(r, "scan");
    const auto geometries = r.optional<bool>("geometries", false);
    r.finish();
    return to_json(require_scan(s.store, id), geometries);
  });

  add("scan.list", Role::viewer, false, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    ScanFilter f;
    if (const auto* st = r.raw("state"); st && !st->is_null())
      f.state = parse_scan_state(json_util::get_as<std::string>(*st, "state"), "state");
    if (const auto* sm = r.raw("sample"); sm && !sm->is_null())
      f.sample_id = resolve_sample(s.store, *sm, "sample").id;
    f.offset = read_offset(r);
    f.limit = read_count(r, "limit", 100, kMaxPage);
    r.finish();
    json out = json::array();
    for (const auto& x : s.store.scans(f)) out.push_back(scan_summary(x));
    return out;
  });

  const auto control = [&s](const char* what) {
    return [&s, what](rpc::Call& c) {
      ObjectReader r(c.params, "");
      const auto id = read_id(r, "scan");
      const auto reason = r.optional<std::string>("reason", "");
      r.finish();
      if (reason.size() > 512) throw Error::invalid("reason", "has more than 512 characters");
      const std::string w = what;
      Scan sc = w == "pause"    ? s.instrument.pause(id, actor(c), reason)
                : w == "resume" ? s.instrument.resume(id, actor(c))
                                : s.instrument.cancel(id, actor(c), reason);
      return scan_summary(sc);
    };
  };
  add("scan.pause", Role::technician, true, control("pause"));
  add("scan.resume", Role::technician, true, control("resume"));
  add("scan.cancel", Role::technician, true, control("cancel"));

  add("scan.points", Role::viewer, false, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto id = read_id(r, "scan");
    const auto offset = read_offset(r);
    const auto limit = read_count(r, "limit", 100, kMaxPage);
    r.finish();
    // Served from the stored JSON text as it is: no parse, no print (scan.points is what
    // clients poll).
    const auto progress = s.store.scan_progress(id);
    if (!progress) throw Error(Errc::not_found, fmt::format("scan: scan {} does not exist", id), "scan");
    const auto texts = s.store.point_json(id, offset, limit);
    const auto next = offset + texts.size();
    std::string out = fmt::format(R"({{"scan":{},"offset":{},"points_done":{},"points_total":{},"next_offset":{},"points":[)",
                                  id, offset, progress->first, progress->second,
                                  next < progress->first ? std::to_string(next) : "null");
    for (std::size_t i = 0; i < texts.size(); ++i) {
      if (i) out += ',';
      out += texts[i];
    }
    out += "]}";
    return rpc::RawJson{std::move(out)};
  });

  add("scan.export", Role::viewer, true, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto id = read_id(r, "scan");
    const auto format = r.optional<std::string>("format", "csv");
    r.finish();
    if (format != "csv" && format != "json" && format != "bsdf" && format != "ssdd")
      throw Error::invalid("format", fmt::format("'{}' is not an export format (allowed: csv, "
                                                 "json, bsdf, ssdd)",
                                                 format));
    const auto scan = require_scan(s.store, id);
    if (scan.points_done > kMaxExportPoints)
      throw Error(Errc::unsupported,
                  fmt::format("scan {} has {} points, more than one export carries ({}); page "
                              "through scan.points",
                              id, scan.points_done, kMaxExportPoints),
                  "scan");
    const auto points = s.store.points(id, 0, scan.points_done + 1);
    const auto e = export_scan(scan, points, format);
    return json{{"scan", id}, {"format", e.format}, {"filename", e.filename},
                {"media_type", e.media_type}, {"points", points.size()}, {"content", e.content}};
  });

  // ---- queue -----------------------------------------------------------------------------
  add("queue.status", Role::viewer, false, [&s](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    const auto running = s.instrument.running_scan();
    json waiting = json::array();
    for (const auto& x : s.store.queue()) waiting.push_back(scan_summary(x));
    json run = nullptr;
    if (running)
      if (auto sc = s.store.scan(*running)) run = scan_summary(*sc);
    return json{{"running", std::move(run)},
                {"waiting", std::move(waiting)},
                {"instrument", s.instrument.status()["state"]}};
  });

  add("queue.reorder", Role::technician, false, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto id = read_id(r, "scan");
    if (!r.has("position")) throw Error::invalid("position", "is required (0 = next)");
    const auto position = read_count(r, "position", 0, 1000000);
    r.finish();
    (void)require_scan(s.store, id);
    s.store.reorder(id, position, actor(c));
    s.instrument.wake();
    json waiting = json::array();
    for (const auto& x : s.store.queue()) waiting.push_back(scan_summary(x));
    return json{{"waiting", std::move(waiting)}};
  });

  // ---- alerts ----------------------------------------------------------------------------
  add("alert.list", Role::viewer, false, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    AlertFilter f;
    if (const auto* a = r.raw("acknowledged"); a && !a->is_null())
      f.acknowledged = json_util::get_as<bool>(*a, "acknowledged");
    if (const auto* sc = r.raw("scan"); sc && !sc->is_null()) {
      f.scan_id = json_util::get_as<std::int64_t>(*sc, "scan");
      if (*f.scan_id <= 0) throw Error::invalid("scan", "is not an id (ids are >= 1)");
    }
    if (const auto* sv = r.raw("severity"); sv && !sv->is_null())
      f.min_severity = parse_severity(json_util::get_as<std::string>(*sv, "severity"), "severity");
    f.offset = read_offset(r);
    f.limit = read_count(r, "limit", 100, kMaxPage);
    r.finish();
    json out = json::array();
    for (const auto& a : s.store.alerts(f)) out.push_back(a);
    return out;
  });

  add("alert.ack", Role::technician, false, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto id = read_id(r, "alert");
    r.finish();
    return json(s.alerts.ack(id, actor(c)));
  });

  // ---- twin ------------------------------------------------------------------------------
  add("twin.predict", Role::technician, true, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto* bsdf = r.raw("bsdf");
    const auto* sample = r.raw("sample");
    json plan_json{{"sample", 1}};
    for (const char* key : {"geometries", "grids", "wavelengths"})
      if (const auto* v = r.raw(key)) plan_json[key] = *v;
    std::optional<double> rel_se;
    if (r.has("rel_se")) {
      rel_se = r.required<double>("rel_se");
      if (!(*rel_se >= 1e-4 && *rel_se <= 0.5)) throw Error::out_of_range("rel_se", *rel_se, 1e-4, 0.5);
    }
    r.finish();
    if ((bsdf == nullptr) == (sample == nullptr))
      throw Error::invalid("bsdf", "give exactly one of 'bsdf' (a spec string) and 'sample'");
    std::string spec;
    if (bsdf) spec = json_util::get_as<std::string>(*bsdf, "bsdf");
    else {
      const auto x = resolve_sample(s.store, *sample, "sample");
      if (!x.spec.bsdf)
        throw Error(Errc::invalid_state,
                    fmt::format("sample: '{}' has no reference BSDF to predict with", x.spec.name),
                    "sample");
      spec = *x.spec.bsdf;
    }
    const auto plan = plan_json.get<ScanPlan>();
    if (plan.geometries.size() > kMaxPredict)
      throw Error(Errc::out_of_range,
                  fmt::format("geometries: {} geometries, more than one call predicts ({})",
                              plan.geometries.size(), kMaxPredict),
                  "geometries");
    const auto tw = s.twin.make(spec, plan.wavelengths, bsdf ? "bsdf" : "sample.bsdf");
    auto options = s.twin.options();
    if (rel_se) options.rel_se = *rel_se;
    const auto preds = s.twin.predict(*tw, plan.geometries, options);
    json out = json::array();
    for (const auto& p : preds)
      out.push_back(json{{"geometry", p.geometry},
                         {"wavelengths_nm", p.wavelengths.values()},
                         {"radiance_factor", p.beta},
                         {"std_error", p.std_error},
                         {"samples", p.samples},
                         {"seconds", p.seconds},
                         {"converged", p.diagnostics.converged},
                         {"seen_fraction", p.diagnostics.seen_fraction}});
    return json{{"twin_version", s.twin.version()}, {"bsdf", spec}, {"predictions", std::move(out)}};
  });

  // ---- subscriptions ---------------------------------------------------------------------
  add("subscribe", Role::viewer, false, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    std::set<Topic> topics;
    if (const auto* t = r.raw("topics"); t && !t->is_null()) {
      if (!t->is_array() || t->empty())
        throw Error::invalid("topics", "expected a non-empty array (progress, points, alerts, state)");
      for (std::size_t i = 0; i < t->size(); ++i) {
        const auto field = fmt::format("topics[{}]", i);
        topics.insert(parse_topic(json_util::get_as<std::string>((*t)[i], field), field));
      }
    } else {
      topics = {Topic::progress, Topic::points, Topic::alerts, Topic::state};
    }
    std::optional<std::int64_t> scan;
    if (const auto* sc = r.raw("scan"); sc && !sc->is_null()) {
      scan = json_util::get_as<std::int64_t>(*sc, "scan");
      (void)require_scan(s.store, *scan);
    }
    r.finish();
    if (!c.session->persistent())
      throw Error(Errc::unsupported,
                  "subscriptions need a persistent connection (NDJSON socket or WebSocket), not "
                  "HTTP POST");
    s.hub.subscribe(c.session, topics, scan);
    json names = json::array();
    for (auto t : s.hub.topics(c.session->id())) names.push_back(topic_name(t));
    return json{{"topics", std::move(names)}, {"scan", scan ? json(*scan) : json(nullptr)}};
  });

  add("unsubscribe", Role::viewer, false, [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    std::set<Topic> topics;
    if (const auto* t = r.raw("topics"); t && !t->is_null()) {
      if (!t->is_array()) throw Error::invalid("topics", "expected an array");
      for (std::size_t i = 0; i < t->size(); ++i) {
        const auto field = fmt::format("topics[{}]", i);
        topics.insert(parse_topic(json_util::get_as<std::string>((*t)[i], field), field));
      }
    }
    r.finish();
    json names = json::array();
    for (auto t : s.hub.unsubscribe(c.session->id(), topics)) names.push_back(topic_name(t));
    return json{{"topics", std::move(names)}};
  });
}

}  // namespace gonio::daemon
