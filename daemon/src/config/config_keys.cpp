// The keys of goniod.toml, each described once: how it is read and checked, how it is
// printed (goniod --check-config) and its row in daemon/README.md's key table.
#include <algorithm>
#include <functional>
#include <regex>

#include <fmt/format.h>

#include "config/key_kinds.hpp"
#include "gonio/daemon/config/config.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio::daemon {
namespace {

// ---- checks and conversions of single keys

// The effective configuration is printed (goniod --check-config) and may be pasted into a
// ticket: secrets in a libpq connection string, keyword form (password=...) or URI form
// (postgresql://user:secret@host/db), are shown as ***.
std::string redact_conninfo(const std::string& conninfo) {
  static const std::regex keyword(R"((password\s*=\s*)('(\\.|[^'])*'|\S+))", std::regex::icase);
  static const std::regex uri(R"(^(postgres(ql)?://[^:@/]*:)[^@/]*@)", std::regex::icase);
  return std::regex_replace(std::regex_replace(conninfo, keyword, "$1***"), uri, "$1***@");
}

// [instrument.motion], [instrument.photometer]: handed to the driver registry as they are.
ConfigKey driver_key(std::string_view name, nlohmann::json Config::*side, std::string_view doc) {
  return with_default(
      custom("instrument", name, "table", "", doc,
             [=](ObjectReader& r, Config& c) {
               const auto* t = r.raw(std::string(name));
               if (!t) return;
               if (!t->is_object() || !t->contains("driver"))
                 throw Error::invalid(r.path(std::string(name)), "expected a table with a 'driver' key");
               c.*side = *t;
             },
             [=](const Config& c) { return (c.*side).empty() ? json() : c.*side; }),
      "—");
}

// [instrument.limits] AXIS = [MIN, MAX] in degrees.
ConfigKey limits_key(std::string_view name, double drivers::MotionLimits::*lo,
                     double drivers::MotionLimits::*hi, double min, double max, std::string_view doc) {
  return custom("instrument.limits", name, "[min, max]", range_text(min, max), doc,
                [=](ObjectReader& r, Config& c) {
                  const auto key = std::string(name);
                  const auto* v = r.raw(key);
                  if (!v) return;
                  const auto f = r.path(key);
                  if (!v->is_array() || v->size() != 2) throw Error::invalid(f, "expected [MIN, MAX] in degrees");
                  const double a = json_util::get_as<double>((*v)[0], f + "[0]");
                  const double b = json_util::get_as<double>((*v)[1], f + "[1]");
                  if (!(a >= min && a <= max)) throw Error::out_of_range(f + "[0]", a, min, max, "°");
                  if (!(b >= a && b <= max)) throw Error::out_of_range(f + "[1]", b, a, max, "°");
                  c.limits.*lo = a;
                  c.limits.*hi = b;
                },
                [=](const Config& c) { return json::array({c.limits.*lo, c.limits.*hi}); });
}

// [store]
void store_keys(std::vector<ConfigKey>& k) {
  using C = Config;
  k.push_back(custom(
      "store", "synchronous", "string", "full or normal",
      "`full`: every committed point is fsynced before it is published, so a power cut loses no "
      "acknowledged point (100 modelled cuts mid-scan: none lost, no store corrupt); `normal`: "
      "survives crashes, but a power cut loses every commit since the WAL was last synced (at a "
      "checkpoint, about every 1000 WAL pages): over 20 modelled cuts, each 1–8 points into a scan, "
      "about 70 % of the acknowledged points (102 to 109 of 140 to 154 in three runs) and, in some "
      "runs, whole scan submissions (up to 7) were lost — the store itself stayed intact and the "
      "scans resumed",
      [](ObjectReader& r, Config& c) {
        const auto sync = r.optional<std::string>("synchronous", c.synchronous_full ? "full" : "normal");
        if (sync != "full" && sync != "normal")
          throw Error::invalid("store.synchronous", fmt::format("'{}' is not full or normal", sync));
        c.synchronous_full = sync == "full";
      },
      [](const Config& c) { return json(c.synchronous_full ? "full" : "normal"); }));
  k.push_back(number("store", "min_free_mb", field(&C::min_free_mb), 0, 1e7,
                     "below this much free space (MiB) in the state directory a `storage` warning is "
                     "raised and no new scan starts; a store made read-only by a full disk takes "
                     "writes again once this plus the 1 MiB reserve is free",
                     " MiB"));
  k.push_back(number("store", "retention_days", field(&C::retention_days), 0, 36500,
                     "points of finished scans older than this (days) that the central archive has "
                     "committed are pruned and their space returned; the scans, their verdicts and "
                     "fits stay. 0: keep every point. Without `[archive]` nothing is pruned",
                     " days"));
}

// [instrument]: the profile, the drivers, timeouts, ranging, recovery
void instrument_keys(std::vector<ConfigKey>& k) {
  using C = Config;
  k.push_back(text("instrument", "profile", field(&C::profile), "twin instrument profile: preset or JSON file"));
  k.push_back(driver_key("motion", &C::motion,
                         "driver table: `driver` (`modbus`, `mock`) and that driver's keys"));
  k.push_back(driver_key("photometer", &C::photometer,
                         "driver table: `driver` (`scpi-serial`, `scpi-tcp`, `scpi-usbtmc`, `mock`) and its keys"));
  k.push_back(seconds("instrument", "move_timeout_s", field(&C::move_timeout), 0.1, 3600, "per move"));
  k.push_back(seconds("instrument", "home_timeout_s", field(&C::home_timeout), 0.1, 3600, "per homing"));
  k.push_back(seconds("instrument", "measure_timeout_s", field(&C::measure_timeout), 0.1, 3600,
                      "per photometer reading"));
  k.push_back(seconds("instrument", "settle_s", field(&C::settle), 0, 60, "wait after a move before reading"));
  k.push_back(boolean("instrument", "autorange", field(&C::autorange),
                      "auto-ranging of a photometer with a settable integration time: a saturated "
                      "reading is read again at a quarter of the integration time (dark, reference and "
                      "sample alike) down to `integration_min_ms`, and only then is a device fault; an "
                      "under-exposed one (best channel's net signal below `underexposed_snr` × its "
                      "uncertainty) at four times it, up to `integration_max_ms` and below a setting "
                      "that saturated. Every point records its `integration_ms`. Off: a saturated "
                      "reading pauses the scan"));
  k.push_back(with_default(
      custom("instrument", "integration_ms", "number", range_text(0.001, 3600000),
             "where every point's ranging starts (ms)",
             [](ObjectReader& r, Config& c) {
               if (r.has("integration_ms"))
                 c.integration_ms = r.optional_in<double>("integration_ms", 100, 0.001, 3600000, " ms");
             },
             [](const Config& c) { return c.integration_ms ? json(*c.integration_ms) : json(); }),
      "the photometer's own setting when goniod first reads it"));
  k.push_back(number("instrument", "integration_min_ms", field(&C::integration_min_ms), 0.001, 3600000,
                     "the shortest integration time ranging may use", " ms"));
  k.push_back(then(number("instrument", "integration_max_ms", field(&C::integration_max_ms), 0.001,
                          3600000, "the longest integration time ranging may use", " ms"),
                   [](const Config& c) {
                     if (c.integration_max_ms < c.integration_min_ms)
                       throw Error::invalid("instrument.integration_max_ms", "must be at least integration_min_ms");
                     if (c.integration_ms &&
                         (*c.integration_ms < c.integration_min_ms || *c.integration_ms > c.integration_max_ms))
                       throw Error::out_of_range("instrument.integration_ms", *c.integration_ms,
                                                 c.integration_min_ms, c.integration_max_ms, " ms");
                   }));
  k.push_back(number("instrument", "underexposed_snr", field(&C::underexposed_snr), 0, 1e6,
                     "a sample reading whose best channel's (S − D)/u is below this is under-exposed"));
  k.push_back(boolean("instrument", "auto_resume", field(&C::auto_resume),
                      "resume a scan paused by a device fault by itself"));
  k.push_back(seconds("instrument", "auto_resume_delay_s", field(&C::auto_resume_delay), 0, 86400,
                      "… after this"));
  k.push_back(integer("instrument", "max_auto_resumes", field(&C::max_auto_resumes), 0, 1000,
                      "… at most this many times per scan"));
  k.push_back(seconds("instrument", "reconnect_initial_s", field(&C::reconnect_initial), 0.01, 3600,
                      "a device whose link failed is reopened after this, then after twice the previous wait"));
  k.push_back(then(seconds("instrument", "reconnect_max_s", field(&C::reconnect_max), 0.01, 86400,
                           "… at most this"),
                   [](const Config& c) {
                     if (c.reconnect_max < c.reconnect_initial)
                       throw Error::invalid("instrument.reconnect_max_s", "must be at least reconnect_initial_s");
                   }));
}

// [instrument.limits]: the motion guard's table
void limits_keys(std::vector<ConfigKey>& k) {
  using L = drivers::MotionLimits;
  k.push_back(limits_key("incidence", &L::incidence_min, &L::incidence_max, 0, 89.9,
                         "soft limits, degrees: the one limits table, checked before every move "
                         "reaches the motion driver"));
  k.push_back(limits_key("receive", &L::receive_min, &L::receive_max, -180, 180, "soft limits, degrees"));
  k.push_back(limits_key("rotation", &L::rotation_min, &L::rotation_max, -360, 360, "soft limits, degrees"));
  k.push_back(limits_key("tilt", &L::tilt_min, &L::tilt_max, -360, 360, "soft limits, degrees"));
  k.push_back(with_default(
      custom("instrument.limits", "min_separation", "number", range_text(0, 179),
             "arm collision clearance over the swept path, degrees: the closest \\|θi + θr\\| may "
             "come. The beams alone need 2.85° on the GCMS-4 (half of each in-plane aperture plus "
             "both arms' ±0.5°); the rest is for the arm housings: set your installation's "
             "measured clearance",
             [](ObjectReader& r, Config& c) {
               if (r.has("min_separation"))
                 c.limits.min_separation = r.optional_in<double>("min_separation", 0, 0, 179);
             },
             [](const Config& c) { return c.limits.min_separation ? json(*c.limits.min_separation) : json(); }),
      "mock: its profile's (gcms4: 10); otherwise 10"));
}

// [twin]: the prediction's estimator
void twin_keys(std::vector<ConfigKey>& k) {
  using C = Config;
  k.push_back(integer("twin", "threads", field(&C::twin_threads), 0, 256, "twin workers (0: one per core)"));
  k.push_back(number("twin", "rel_se", field(&C::twin_rel_se), 1e-5, 0.5,
                     "relative standard error every prediction aims at"));
  k.push_back(integer("twin", "max_samples", field(&C::twin_max_samples), 1024, 1ll << 34,
                      "paths per prediction, at most"));
  k.push_back(integer("twin", "replicates", field(&C::twin_replicates), 4, 1024,
                      "independent scramblings that give the standard error"));
  k.push_back(integer("twin", "seed", field(&C::twin_seed), 0, 1ll << 62, "the estimator's seed"));
  k.push_back(with_default(
      then(text("twin", "data_dir", field(&C::twin_data_dir),
                "the only place BSDF specs from clients (`sample.create`, `twin.predict`, "
                "`scan.fit`) may read `@file`s: relative names, no `..`, no links, regular files only"),
           [](const Config& c) {
             if (!c.twin_data_dir.empty() && c.twin_data_dir.front() != '/')
               throw Error::invalid("twin.data_dir", fmt::format("'{}' must be an absolute path", c.twin_data_dir));
           }),
      "`<state-dir>/data`"));
}

// [divergence]: the decision rule and what a verdict does
void divergence_keys(std::vector<ConfigKey>& k) {
  using C = Config;
  k.push_back(number("divergence", "coverage_k", field(&C::coverage_k), 0.5, 10,
                     "coverage factor k of the decision rule "
                     "([docs/decision-rule.md](../docs/decision-rule.md))"));
  k.push_back(number("divergence", "z_threshold", field(&C::z_threshold), 0.5, 100,
                     "a point with max \\|m − p\\|/u_c above this is flagged `inconsistent` (a "
                     "figure, not the decision)"));
  k.push_back(number("divergence", "delta_e_threshold", field(&C::delta_e_threshold), 0.1, 100,
                     "the colour's acceptance limit, ΔE00, where CIELAB is defined (β ≤ 1)"));
  k.push_back(number("divergence", "delta_uv_threshold", field(&C::delta_uv_threshold), 1e-4, 0.1,
                     "… and above β = 1, the chromaticity distance Δu′v′"));
  k.push_back(number("divergence", "reference_drift", field(&C::reference_drift), 0.001, 1,
                     "relative drift of the reference white reading: health alert"));
  k.push_back(boolean("divergence", "pause_on_sustained", field(&C::pause_on_sustained),
                      "pause the scan when its verdict raises the sustained divergence alert"));
  k.push_back(boolean("divergence", "diagnose", field(&C::diagnose),
                      "at the end of a scan whose verdict raised the alert, refit the named cause "
                      "through the inverse twin and append it to the alert"));
}

// [webhook]
void webhook_keys(std::vector<ConfigKey>& k) {
  using C = Config;
  k.push_back(with_default(text("webhook", "url", field(&C::webhook_url),
                                "`http://HOST:PORT/PATH`: new alerts are POSTed as JSON"),
                           "—"));
  k.push_back(integer("webhook", "retries", field(&C::webhook_retries), 0, 100,
                      "delivery attempts after the first, with exponential back-off, one alert at a time"));
  k.push_back(seconds("webhook", "backoff_s", field(&C::webhook_backoff), 0.01, 3600, "the first back-off"));
  k.push_back(seconds("webhook", "timeout_s", field(&C::webhook_timeout), 0.1, 600, "per POST"));
  k.push_back(one_of("webhook", "min_severity", &C::webhook_min_severity, {"info", "warning", "critical"},
                     "info, warning or critical", "alerts below this are not POSTed"));
}

// [mqtt]: telemetry
void mqtt_keys(std::vector<ConfigKey>& k) {
  using C = Config;
  using M = Config::Mqtt;
  k.push_back(with_default(
      text("mqtt", "url", field(&C::mqtt, &M::url),
           "`mqtt://HOST[:PORT]` (1883) or `mqtts://HOST[:PORT]` (8883): publish telemetry there "
           "(below); empty: no MQTT"),
      "—"));
  k.push_back(with_default(text("mqtt", "instrument", field(&C::mqtt, &M::instrument),
                                "this instrument's id in topics: 1–64 of `A-Z a-z 0-9 . _ -`"),
                           "the host name"));
  k.push_back(with_default(text("mqtt", "username", field(&C::mqtt, &M::username), "broker credentials"), "—"));
  k.push_back(with_default(
      custom("mqtt", "password", "string", "", "… printed as `***`",
             [](ObjectReader& r, Config& c) { c.mqtt.password = r.optional<std::string>("password", c.mqtt.password); },
             [](const Config& c) { return json(c.mqtt.password.empty() ? "" : "***"); }),
      "—"));
  k.push_back(integer("mqtt", "qos", field(&C::mqtt, &M::qos), 0, 2, "every message"));
  k.push_back(text("mqtt", "topic_prefix", field(&C::mqtt, &M::topic_prefix),
                   "first topic level(s), e.g. `lab3/gonio`"));
  k.push_back(with_default(text("mqtt", "ca_file", field(&C::mqtt, &M::ca_file),
                                "mqtts only: the broker's CA (PEM)"),
                           "system CAs"));
  k.push_back(with_default(text("mqtt", "cert_file", field(&C::mqtt, &M::cert_file),
                                "mqtts only: a client certificate …"),
                           "—"));
  k.push_back(with_default(text("mqtt", "key_file", field(&C::mqtt, &M::key_file), "… and its key"), "—"));
  k.push_back(integer("mqtt", "queue", field(&C::mqtt, &M::queue), 16, 1000000,
                      "telemetry messages waiting for the broker; beyond, the oldest is dropped and counted"));
  k.push_back(integer("mqtt", "keepalive_s", field(&C::mqtt, &M::keepalive_s), 5, 3600,
                      "MQTT keep-alive, seconds"));
}

// [archive]: the central PostgreSQL archive
void archive_keys(std::vector<ConfigKey>& k) {
  using C = Config;
  using A = Config::Archive;
  k.push_back(with_default(
      custom("archive", "postgres", "string", "",
             "libpq connection string or URI of the central archive (below); empty: no archive; "
             "a password in it is printed as `***`",
             [](ObjectReader& r, Config& c) { c.archive.postgres = r.optional<std::string>("postgres", c.archive.postgres); },
             [](const Config& c) { return json(redact_conninfo(c.archive.postgres)); }),
      "—"));
  k.push_back(with_default(text("archive", "instrument", field(&C::archive, &A::instrument),
                                "this instrument's id in the archive: 1–64 of `A-Z a-z 0-9 . _ -`"),
                           "the host name"));
  k.push_back(integer("archive", "batch", field(&C::archive, &A::batch), 1, 5000,
                      "outbox rows per PostgreSQL transaction"));
  k.push_back(seconds("archive", "retry_max_s", field(&C::archive, &A::retry_max), 0.1, 3600,
                      "reconnection back-off cap; a connection string without `connect_timeout` gets 10 s"));
  k.push_back(seconds("archive", "max_backlog_age_s", field(&C::archive, &A::max_backlog_age), 1, 7 * 86400,
                      "an outbox row older than this raises an `archive_backlog` warning"));
}

std::vector<ConfigKey> make_keys() {
  std::vector<ConfigKey> k;
  for (auto* section : {server_keys, tls_keys, auth_keys, store_keys, instrument_keys, limits_keys, twin_keys,
                        divergence_keys, webhook_keys, mqtt_keys, archive_keys})
    section(k);
  return k;
}

// Keys that still load but do nothing: a kept configuration is not refused for them.
struct Retired {
  std::string_view section, name, why;
};
constexpr Retired kRetired[] = {
    {"divergence", "sustained_m", "the scan's verdict decides when a divergence is sustained"},
    {"divergence", "sustained_n", "the scan's verdict decides when a divergence is sustained"},
};

// The sections in file order, each before the sections inside it.
std::vector<std::string_view> sections() {
  std::vector<std::string_view> out;
  for (const auto& key : config_keys())
    if (std::find(out.begin(), out.end(), key.section) == out.end()) out.push_back(key.section);
  return out;
}

json sub_table(ObjectReader& r, const std::string& key) {
  const auto* t = r.raw(key);
  if (!t) return json::object();
  if (!t->is_object()) throw Error::invalid(r.path(key), "expected a table");
  return *t;
}

// Reads the table at `path` and the sections inside it.
void read_section(const json& table, std::string_view path, Config& c) {
  if (table.empty()) return;
  ObjectReader r(table, std::string(path));
  for (const auto& key : config_keys())
    if (key.section == path) key.read(r, c);
  for (const auto& gone : kRetired)
    if (gone.section == path && r.raw(std::string(gone.name)))
      c.warnings.push_back(fmt::format("{}.{} is no longer used: {}", gone.section, gone.name, gone.why));
  for (const auto child : sections()) {
    const auto dot = child.rfind('.');
    const auto parent = dot == std::string_view::npos ? std::string_view() : child.substr(0, dot);
    if (parent == path && child != path)
      read_section(sub_table(r, std::string(child.substr(dot + 1))), child, c);
  }
  r.finish();
}

// A default as the README writes it: 10 rather than 10.0, [0, 85], `info`, — for none.
std::string value_text(const json& v) {
  if (v.is_number_float()) return fmt::format("{}", v.get<double>());
  if (v.is_array()) {
    std::string items;
    for (const auto& e : v) items += (items.empty() ? "" : ", ") + value_text(e);
    return "[" + items + "]";
  }
  return v.dump();
}

std::string default_cell(const ConfigKey& key) {
  if (!key.default_text.empty()) return std::string(key.default_text);
  const auto v = key.write(Config{});
  if (v.is_string()) return v.get<std::string>().empty() ? "—" : fmt::format("`{}`", v.get<std::string>());
  if (v.is_array()) return fmt::format("`{}`", value_text(v));
  return value_text(v);
}

}  // namespace

std::span<const ConfigKey> config_keys() {
  static const std::vector<ConfigKey> keys = make_keys();
  return keys;
}

Config Config::parse(std::string_view text, std::string_view source, const std::optional<Config>& base) {
  const json doc = toml_to_json(text, source);
  Config c = base.value_or(Config{});
  ObjectReader top(doc, "");
  for (const auto section : sections())
    if (section.find('.') == std::string_view::npos)
      read_section(sub_table(top, std::string(section)), section, c);
  top.finish();
  c.validate();
  return c;
}

json Config::to_json() const {
  json doc = json::object();
  for (const auto& key : config_keys()) {
    auto value = key.write(*this);
    if (value.is_null()) continue;  // unset: its default is decided at start
    json* table = &doc;
    for (std::size_t from = 0; from <= key.section.size();) {  // "auth.unix" -> doc["auth"]["unix"]
      const auto dot = std::min(key.section.find('.', from), key.section.size());
      table = &(*table)[std::string(key.section.substr(from, dot - from))];
      from = dot + 1;
    }
    (*table)[std::string(key.name)] = std::move(value);
  }
  return doc;
}

std::string config_key_table() {
  std::string out = "| key | type | default | allowed | meaning |\n|---|---|---|---|---|\n";
  for (const auto& key : config_keys())
    out += fmt::format("| `{}.{}` | {} | {} | {} | {} |\n", key.section, key.name, key.type,
                       default_cell(key), key.range.empty() ? "" : key.range, key.doc);
  return out;
}

}  // namespace gonio::daemon
