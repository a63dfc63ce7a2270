// The system.* methods (system.info, what monitors poll, and the audit log), and the
// resident-memory figure system.info reports.
#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <charconv>
#include <chrono>

#include "gonio/proto/version.hpp"
#include "methods/params.hpp"
#include "methods/registrar.hpp"


namespace gonio::daemon {

using json_util::ObjectReader;
using nlohmann::json;

namespace {

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

// "http://user:pw@host:port/path?q" -> "http://host:port".
std::string webhook_host(const json& url) {
  if (!url.is_string()) return {};
  auto u = url.get<std::string>();
  const auto scheme_end = u.find("://");
  const auto start = scheme_end == std::string::npos ? 0 : scheme_end + 3;
  auto end = u.find_first_of("/?#", start);
  if (end == std::string::npos) end = u.size();
  auto authority = u.substr(start, end - start);
  if (const auto at = authority.rfind('@'); at != std::string::npos) authority.erase(0, at + 1);
  return u.substr(0, start) + authority;
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

void register_system(MethodRegistrar& reg, Services& s) {
  // system.info is what monitors poll: the members fixed at start are serialised once, the
  // others are written straight to text by a JsonWriter (no JSON tree per call). Members
  // come in no particular order.
  const auto fixed = [&s] {
    std::string t = json{{"name", "goniod"},
                         {"version", proto::kVersion},
                         {"api_version", openrpc_document()["info"]["version"]},
                         {"schema_version", Store::kSchemaVersion},
                         {"started_at", s.started_at},
                         {"state_dir", s.state_dir.string()},
                         {"divergence", {{"coverage_k", s.config.coverage_k},
                                         {"z_threshold", s.config.z_threshold},
                                         {"delta_e_threshold", s.config.delta_e_threshold},
                                         {"delta_uv_threshold", s.config.delta_uv_threshold},
                                         {"reference_drift", s.config.reference_drift}}}}
                        .dump();
    t.pop_back();  // the closing brace comes after the live members
    return t;
  }();
  const auto twin_version = json(s.twin.version()).dump();
  const auto twin_threads = s.twin.threads();
  reg.add("system.info", [&s, fixed, twin_version, twin_threads](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    const auto uptime = std::chrono::duration<double>(std::chrono::steady_clock::now() - s.started).count();
    std::string out;
    out.reserve(fixed.size() + 2048);  // the live members, and the envelope around them
    out += fixed;
    JsonWriter w(out);
    w.member("uptime_s", uptime)
        .member("running_scan", s.instrument.running_scan())
        .member("rss_bytes", sampled_resident_bytes())
        .begin_object("rpc")
        .member("requests", s.dispatcher ? s.dispatcher->requests() : 0)
        .member("errors", s.dispatcher ? s.dispatcher->errors() : 0)
        .member("abandoned", s.dispatcher ? s.dispatcher->abandoned() : 0)
        .member("building_bytes", s.dispatcher ? s.dispatcher->building_bytes() : 0)
        .member("building_refused", s.dispatcher ? s.dispatcher->building_refused() : 0)
        .end_object()
        .member("subscribers", s.hub.sessions())
        .member("notifications_dropped", s.hub.dropped())
        .raw_member("runner", s.instrument.stats_text())
        .begin_object("twin")
        .raw_member("version", twin_version)
        .member("threads", twin_threads)
        .member("queued", s.twin.queued())
        .end_object()
        .begin_object("you");
    methods::write_principal(w, c.principal);
    w.end_object();
    if (auto sink = s.alerts.sink()) {
      auto hook = sink->stats();
      // The URL may carry a path or a query meant as a secret: only admins see it whole.
      if (c.principal.role < Role::admin && hook.contains("url")) hook["url"] = webhook_host(hook["url"]);
      w.raw_member("webhook", hook.dump());
    }
    if (s.mqtt) w.raw_member("mqtt", s.mqtt->status().dump());
    if (s.archive) w.raw_member("archive", s.archive->status().dump());
    const auto section = [&w](std::string_view key, const auto& write, bool array) {
      if (!write) return;
      array ? w.begin_array(key) : w.begin_object(key);
      write(w);
      array ? w.end_array() : w.end_object();
    };
    section("transport", s.transport_stats, true);
    section("net", s.net_stats, false);
    section("governor", s.governor_stats, false);
    w.end_object();
    return rpc::RawJson{std::move(out)};
  });

  reg.add("system.audit", [&s](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto offset = methods::read_offset(r);
    const auto limit = methods::read_count(r, "limit", 100, methods::kMaxPage);
    r.finish();
    json out = json::array();
    for (const auto& e : s.store.audit_events(offset, limit))
      out.push_back(json{{"id", e.id}, {"at", e.at}, {"actor", e.actor}, {"action", e.action},
                         {"target", e.target}, {"detail", e.detail}});
    return out;
  });
}

}  // namespace gonio::daemon
