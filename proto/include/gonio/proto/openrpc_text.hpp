// The JSON-RPC API document (proto/openrpc.json), embedded at build time
// (cmake/embed_text.cmake): goniod serves it from rpc.discover.
#pragma once

extern const char* const gonio_openrpc_json;
