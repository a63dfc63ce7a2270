// The JSON-RPC methods of goniod (documented in proto/openrpc.json and daemon/README.md; each
// method's role and blocking are in gonio/daemon/methods/method_table.hpp).
#pragma once

#include <chrono>
#include <filesystem>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "gonio/daemon/config/config.hpp"
#include "gonio/daemon/fleet/archive.hpp"
#include "gonio/daemon/fleet/mqtt.hpp"
#include "gonio/daemon/instrument/alerts.hpp"
#include "gonio/daemon/instrument/instrument.hpp"
#include "gonio/daemon/instrument/twin_service.hpp"
#include "gonio/daemon/rpc/auth.hpp"
#include "gonio/daemon/rpc/hub.hpp"
#include "gonio/daemon/rpc/rpc.hpp"
#include "gonio/proto/json_writer.hpp"
#include "gonio/daemon/store/store.hpp"

namespace gonio::daemon {

// The OpenRPC document (proto/openrpc.json), embedded at build time.
const std::string& openrpc_text();
const nlohmann::json& openrpc_document();

struct Services {
  const Config& config;
  std::filesystem::path state_dir;
  Store& store;
  Auth& auth;
  Hub& hub;
  TwinService& twin;
  AlertService& alerts;
  Instrument& instrument;
  const rpc::Dispatcher* dispatcher = nullptr;
  std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();
  std::string started_at;
  // system.info's live members, written into an open array or object (JsonWriter).
  std::function<void(JsonWriter&)> transport_stats;  // one object per listener
  std::function<void(JsonWriter&)> net_stats;        // budgets and dropped peers (net::NetStats)
  std::function<void(const std::string&)> end_sessions_of;  // a token was revoked
  std::filesystem::path data_dir;  // where BSDF specs' '@file' names may point (twin.data_dir)
  ArchiveShipper* archive = nullptr;  // null: no [archive]
  MqttPublisher* mqtt = nullptr;      // null: no [mqtt]
  std::function<void(JsonWriter&)> governor_stats;  // the client governor (rpc/governor.hpp)
};

void register_methods(rpc::Dispatcher& d, Services& s);

// Resident set size of this process in bytes (/proc/self/statm), 0 when unknown.
std::size_t resident_bytes();

}  // namespace gonio::daemon
