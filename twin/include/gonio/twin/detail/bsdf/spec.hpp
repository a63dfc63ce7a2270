// The BSDF spec, parsed but not yet built: a list of lobes, each a model name with its
// key=value arguments, or a tabulated file. Parsing does no file I/O and knows nothing of
// the models' parameter tables; make_bsdf validates and builds (factory.cpp).
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "gonio/twin/detail/bsdf/spectral_param.hpp"

namespace gonio::twin::bsdf {

struct LobeSpec {
  std::string name;                                   // model name; empty for a file lobe
  std::vector<std::pair<std::string, RawValue>> args; // in the order given
  std::string file;                                   // tabulated BSDF file ("@path")
};

inline constexpr std::size_t kMaxSpecBytes = 1u << 20;
inline constexpr std::size_t kMaxLobes = 64;

// Spec string: lobes joined by '+' (split only where '+' is followed by a lobe name or
// '@'), each "name", "name:key=value,key=value" or "@path". Throws Error(invalid_argument).
std::vector<LobeSpec> parse_spec_string(std::string_view spec);

// JSON form: a spec string, an object {"type": name, key: value...} or
// {"type": "file", "path": ...}, or an array of those (a sum).
std::vector<LobeSpec> parse_spec_json(const nlohmann::json& spec);

}  // namespace gonio::twin::bsdf
