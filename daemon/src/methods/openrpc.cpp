// The embedded OpenRPC document (proto/openrpc.json, embedded by the proto library).
#include <string>

#include <nlohmann/json.hpp>

#include "gonio/daemon/methods/methods.hpp"
#include "gonio/proto/openrpc_text.hpp"

namespace gonio::daemon {

const std::string& openrpc_text() {
  static const std::string text = gonio_openrpc_json;
  return text;
}

const nlohmann::json& openrpc_document() {
  static const nlohmann::json doc = nlohmann::json::parse(openrpc_text());
  return doc;
}

}  // namespace gonio::daemon
