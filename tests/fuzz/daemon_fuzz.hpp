// What the daemon-facing fuzz targets share: goniod's real services on the built-in mock
// (store in a scratch directory, tokens, twin, alerts, the instrument with its devices
// opened), every JSON-RPC method registered, and a check that a reply is well-formed
// JSON-RPC 2.0. Built once per process and never torn down (libFuzzer exits from inside).
//
// The instrument's runner thread is stopped right after the devices are opened: every
// input's effect is then its dispatch alone (parse, params, handler, store), and a scan
// that an input submits is validated and queued but not measured in the background, which
// would make runs depend on timing. Manual commands answer "goniod is stopping".
#pragma once

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include <unistd.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "gonio/daemon/config/config.hpp"
#include "gonio/daemon/instrument/alerts.hpp"
#include "gonio/daemon/instrument/instrument.hpp"
#include "gonio/daemon/instrument/twin_service.hpp"
#include "gonio/daemon/methods/methods.hpp"
#include "gonio/daemon/rpc/auth.hpp"
#include "gonio/daemon/rpc/hub.hpp"
#include "gonio/daemon/rpc/rpc.hpp"
#include "gonio/daemon/store/store.hpp"
#include "gonio/twin/instrument.hpp"

namespace gonio::fuzz {

using daemon::Role;

class FuzzSession final : public daemon::rpc::Session {
 public:
  explicit FuzzSession(Role role) : Session("fuzz", "fuzz", true) {
    daemon::Principal p;
    p.name = "fuzz";
    p.role = role;
    p.transport = "fuzz";
    set_principal(p);
  }
  bool push(std::shared_ptr<const std::string>) override { return true; }
};

struct FuzzDaemon {
  FuzzDaemon()
      : dir(std::filesystem::temp_directory_path() / fmt::format("gonio-fuzz-{}", ::getpid())),
        config(make_config()),
        dispatcher([](std::uint64_t, std::function<void()> f) { f(); }) {
    spdlog::set_level(spdlog::level::off);
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    store.emplace(dir / "goniod.db", false);
    auth.emplace(std::vector<daemon::TokenEntry>{}, *store);
    twin.emplace(config, twin::InstrumentProfile::preset("gcms4"));
    alerts.emplace(*store, hub);
    instrument.emplace(config, *store, *twin, *alerts, hub);
    instrument->start();
    instrument->shutdown();
    services.emplace(daemon::Services{config, dir, *store, *auth, hub, *twin, *alerts, *instrument,
                                      &dispatcher, std::chrono::steady_clock::now(), utc::now(),
                                      nullptr, nullptr, nullptr, dir, nullptr, nullptr, nullptr});
    daemon::register_methods(dispatcher, *services);
    std::atexit([] { std::filesystem::remove_all(get().dir); });
  }

  static daemon::Config make_config() {
    auto c = daemon::Config::mock_defaults();
    c.twin_threads = 1;
    c.twin_rel_se = 0.5;  // predictions an input asks for stay cheap
    c.twin_max_samples = 1024;
    c.twin_replicates = 4;
    c.synchronous_full = false;
    c.max_message_bytes = 1 << 16;
    return c;
  }

  static FuzzDaemon& get() {
    static auto* d = new FuzzDaemon;  // reachable to the end: libFuzzer exits from inside
    return *d;
  }

  std::filesystem::path dir;
  daemon::Config config;
  std::optional<daemon::Store> store;
  std::optional<daemon::Auth> auth;
  std::optional<daemon::TwinService> twin;
  daemon::Hub hub;
  std::optional<daemon::AlertService> alerts;
  std::optional<daemon::Instrument> instrument;
  daemon::rpc::Dispatcher dispatcher;
  std::optional<daemon::Services> services;
};

[[noreturn]] inline void fail(std::string_view why, std::string_view reply) {
  std::fprintf(stderr, "malformed JSON-RPC reply: %.*s\nreply: %.*s\n", static_cast<int>(why.size()),
               why.data(), static_cast<int>(std::min<std::size_t>(reply.size(), 2000)), reply.data());
  std::abort();
}

// One response object: {"jsonrpc": "2.0", "id": ..., "result": ...} or with "error":
// {"code": integer, "message": string, ...} and nothing else.
inline void check_response(const nlohmann::json& r, std::string_view text) {
  if (!r.is_object()) fail("a response is not an object", text);
  if (r.value("jsonrpc", "") != "2.0") fail("no \"jsonrpc\": \"2.0\"", text);
  if (!r.contains("id")) fail("no id", text);
  const auto& id = r["id"];
  if (!id.is_null() && !id.is_string() && !id.is_number()) fail("id is not null, a string or a number", text);
  if (r.contains("result") == r.contains("error")) fail("not exactly one of result and error", text);
  if (r.size() != 3) fail("members other than jsonrpc, id and result/error", text);
  if (r.contains("error")) {
    const auto& e = r["error"];
    if (!e.is_object() || !e.contains("code") || !e["code"].is_number_integer() ||
        !e.contains("message") || !e["message"].is_string())
      fail("error is not {code: integer, message: string}", text);
  }
}

// A whole reply: empty (nothing to answer), one response, or a non-empty array of them.
inline void check_reply(std::string_view text) {
  if (text.empty()) return;
  const auto j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded()) fail("not JSON", text);
  if (j.is_array()) {
    if (j.empty()) fail("an empty batch reply", text);
    for (const auto& r : j) check_response(r, text);
  } else {
    check_response(j, text);
  }
}

}  // namespace gonio::fuzz
