// Tabulated BSDF files chosen by extension: the `@file` spec of make_bsdf and the `convert`
// command both come through here.
#include <algorithm>
#include <cctype>
#include <filesystem>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf_io.hpp"

namespace gonio::twin {
namespace {

constexpr std::string_view kAllowed =
    ".bsdf (Zemax/Radiant IS-SA), .ssdd (SSDD), .binary (MERL)";

std::string extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

void require_file(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw Error(Errc::not_found, fmt::format("tabulated BSDF file '{}' does not exist", path),
                "path");
}

}  // namespace

TabulatedParts read_bsdf_file(const std::string& path) {
  const std::string ext = extension(path);
  if (ext != ".bsdf" && ext != ".ssdd" && ext != ".binary")
    throw Error(Errc::invalid_argument,
                fmt::format("'{}': unknown tabulated BSDF extension '{}'; allowed: {}", path,
                            ext, kAllowed),
                "path");
  require_file(path);
  if (ext == ".bsdf") return read_issa(path);
  if (ext == ".ssdd") return read_ssdd(path);
  return read_merl(path);
}

BsdfPtr load_bsdf_file(const std::string& path, const WavelengthGrid& grid) {
  return std::make_shared<TabulatedBsdf>(grid, read_bsdf_file(path), "@" + path);
}

std::vector<std::string> write_bsdf_file(const std::string& path, const TabulatedParts& parts,
                                         const IssaWriteOptions& issa,
                                         const SsddWriteOptions& ssdd) {
  const std::string ext = extension(path);
  if (ext == ".ssdd") return write_ssdd(path, parts, ssdd);
  if (ext != ".bsdf")
    throw Error(Errc::invalid_argument,
                fmt::format("'{}': cannot write extension '{}'; allowed: .bsdf (IS-SA), .ssdd",
                            path, ext),
                "path");
  if (parts.brdf && parts.btdf)
    throw Error(Errc::unsupported,
                fmt::format("'{}': an IS-SA file holds one ScatterType; this BSDF has a BRDF "
                            "and a BTDF (write .ssdd, or one file per part)", path),
                "path");
  if (parts.specular_reflectance || parts.specular_transmittance)
    throw Error(Errc::unsupported,
                fmt::format("'{}': IS-SA files cannot hold ideal specular parts (write .ssdd)",
                            path),
                "path");
  if (!parts.brdf && !parts.btdf) throw Error::invalid("parts", "hold no BRDF or BTDF");
  return write_issa(path, parts.brdf ? *parts.brdf : *parts.btdf, !parts.brdf, issa);
}

}  // namespace gonio::twin
