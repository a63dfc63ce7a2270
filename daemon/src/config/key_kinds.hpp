// How the key table of goniod.toml is written (config_keys.cpp, server_keys.cpp): the kinds of
// key and their accessors. Each key is described once: how it is read and checked, how it is
// printed (goniod --check-config) and its row in daemon/README.md's key table.
#pragma once

#include <algorithm>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>

#include "gonio/daemon/config/config.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio::daemon {

// The sections of the table written in server_keys.cpp, each appending its keys in file order.
void server_keys(std::vector<ConfigKey>& k);  // [server]: listeners and their limits
void tls_keys(std::vector<ConfigKey>& k);     // [server.tls]
void auth_keys(std::vector<ConfigKey>& k);    // [auth], [auth.unix]

namespace {  // each file that writes keys has its own copy

using json_util::ObjectReader;
using nlohmann::json;

// ---- accessors: one generic lambda reaches a field of a Config, const or not

template <class T>
auto field(T Config::*m) {
  return [m](auto& c) -> auto& { return c.*m; };
}
template <class S, class T>
auto field(S Config::*s, T S::*m) {
  return [s, m](auto& c) -> auto& { return (c.*s).*m; };
}

inline std::string range_text(double lo, double hi) { return fmt::format("{}–{}", lo, hi); }

inline double in_seconds(milliseconds ms) { return static_cast<double>(ms.count()) / 1000.0; }

// ---- the kinds of key

template <class Get>
ConfigKey boolean(std::string_view section, std::string_view name, Get get, std::string_view doc) {
  return {section, name, "bool", "", "", doc,
          [=](ObjectReader& r, Config& c) { get(c) = r.optional<bool>(std::string(name), get(c)); },
          [=](const Config& c) { return json(get(c)); }};
}

template <class Get>
ConfigKey integer(std::string_view section, std::string_view name, Get get, long long lo,
                  long long hi, std::string_view doc) {
  return {section, name, "integer", fmt::format("{}–{}", lo, hi), "", doc,
          [=](ObjectReader& r, Config& c) {
            auto& v = get(c);
            v = static_cast<std::remove_reference_t<decltype(v)>>(
                r.optional_in<long long>(std::string(name), static_cast<long long>(v), lo, hi));
          },
          [=](const Config& c) { return json(get(c)); }};
}

template <class Get>
ConfigKey number(std::string_view section, std::string_view name, Get get, double lo, double hi,
                 std::string_view doc, std::string_view unit = {}) {
  return {section, name, "number", range_text(lo, hi), "", doc,
          [=](ObjectReader& r, Config& c) { get(c) = r.optional_in<double>(std::string(name), get(c), lo, hi, unit); },
          [=](const Config& c) { return json(get(c)); }};
}

// A duration, written in seconds (the key's name ends in _s), kept in milliseconds.
template <class Get>
ConfigKey seconds(std::string_view section, std::string_view name, Get get, double lo_s,
                  double hi_s, std::string_view doc) {
  return {section, name, "seconds", range_text(lo_s, hi_s), "", doc,
          [=](ObjectReader& r, Config& c) {
            const double s = r.optional_in(std::string(name), in_seconds(get(c)), lo_s, hi_s);
            get(c) = milliseconds(static_cast<long long>(s * 1000.0 + 0.5));
          },
          [=](const Config& c) { return json(in_seconds(get(c))); }};
}

template <class Get>
ConfigKey text(std::string_view section, std::string_view name, Get get, std::string_view doc) {
  return {section, name, "string", "", "", doc,
          [=](ObjectReader& r, Config& c) { get(c) = r.optional<std::string>(std::string(name), get(c)); },
          [=](const Config& c) { return json(get(c)); }};
}

// A key with its own reading and printing; `type` and `range` as the README shows them.
inline ConfigKey custom(std::string_view section, std::string_view name, std::string_view type,
                 std::string range, std::string_view doc, ConfigKey::Reader read,
                 ConfigKey::Writer write) {
  return {section, name, type, std::move(range), "", doc, std::move(read), std::move(write)};
}

inline ConfigKey with_default(ConfigKey k, std::string_view shown) {
  k.default_text = shown;
  return k;
}

// A key read as the kind `k` is, then checked against the keys read before it.
inline ConfigKey then(ConfigKey k, std::function<void(const Config&)> check) {
  k.read = [read = std::move(k.read), check = std::move(check)](ObjectReader& r, Config& c) {
    read(r, c);
    check(c);
  };
  return k;
}

inline ConfigKey one_of(std::string_view section, std::string_view name, std::string Config::*m,
                 std::vector<std::string> allowed, std::string_view listed, std::string_view doc) {
  auto k = text(section, name, field(m), doc);
  k.range = listed;
  return then(std::move(k), [=](const Config& c) {
    if (std::find(allowed.begin(), allowed.end(), c.*m) == allowed.end())
      throw Error::invalid(fmt::format("{}.{}", section, name),
                           fmt::format("'{}' is not {}", c.*m, listed));
  });
}

}  // namespace
}  // namespace gonio::daemon
