// Moving a file over JSON-RPC in pieces (backup.read): each piece's bytes as base64 text
// (RFC 4648 §4) and the file's SHA-256 (FIPS 180-4), computed piece by piece, which the
// receiver checks against the one the sender announced. OpenSSL does the encoding and the
// digest.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

namespace gonio::daemon {

std::string base64_encode(std::string_view bytes);
// Throws Error(invalid_argument, field `field`) for text that is not base64.
std::string base64_decode(std::string_view text, std::string_view field = "data");

// An incremental SHA-256.
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void update(std::string_view bytes);
  std::string hex();  // finishes: call once

 private:
  struct Ctx;
  std::unique_ptr<Ctx> ctx_;
};

// The SHA-256 of a file's contents, as lowercase hex. Throws Error(io_error) naming it.
std::string sha256_file(const std::filesystem::path& file);

}  // namespace gonio::daemon
