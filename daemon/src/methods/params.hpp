// What several method families share: reading ids and pages from params, resolving a sample
// or scan reference, and the common result shapes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "gonio/daemon/rpc/auth.hpp"
#include "gonio/daemon/rpc/rpc.hpp"
#include "gonio/daemon/store/store.hpp"
#include "gonio/proto/json_util.hpp"
#include "gonio/proto/json_writer.hpp"

namespace gonio::daemon::methods {

// The largest page a list method returns.
inline constexpr std::size_t kMaxPage = 1000;

// A required id (>= 1) under `key`.
std::int64_t read_id(json_util::ObjectReader& r, const std::string& key);
// An optional count under `key` in [0, max], `fallback` when absent.
std::size_t read_count(json_util::ObjectReader& r, const std::string& key, std::size_t fallback,
                       std::size_t max);
// The optional "offset" of a page.
std::size_t read_offset(json_util::ObjectReader& r);

// `ref` is a sample id or name; Error(not_found) naming `field` when there is no such sample.
Sample resolve_sample(const Store& store, const nlohmann::json& ref, const std::string& field);
// Error(not_found) naming "scan" when there is no such scan.
Scan require_scan(const Store& store, std::int64_t id);

// A BSDF spec from a client with every '@file' confined to `data_dir`: each path must be
// relative, without '..', of plain characters, and name a regular file reached without
// symbolic links (opened O_NOFOLLOW | O_NONBLOCK component by component, so neither a link
// nor a FIFO gets through). Returns the spec with the paths made absolute. Throws
// Error(invalid_argument) naming `field`.
std::string confine_bsdf_files(const std::string& spec, const std::filesystem::path& data_dir,
                               const std::string& field);

// Who is calling, as written to the audit log.
std::string actor(const rpc::Call& c);
nlohmann::json principal_json(const Principal& p);
// The same members, written into an open object.
void write_principal(JsonWriter& w, const Principal& p);
// A scan without its geometries.
nlohmann::json scan_summary(const Scan& s);

}  // namespace gonio::daemon::methods
