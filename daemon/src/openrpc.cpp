// The embedded OpenRPC document (proto/openrpc.json, generated into openrpc_text.cpp).
#include <string>

#include <nlohmann/json.hpp>

#include "gonio/daemon/methods.hpp"

extern const char* const gonio_openrpc_json;

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
