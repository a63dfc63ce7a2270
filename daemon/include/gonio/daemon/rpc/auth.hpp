// Bearer tokens → roles. Tokens are never stored: only their SHA-256 (FIPS 180-4), from
// the config ([[auth.token]]) and from the store (tokens created over the API and the
// admin token goniod writes on first start). A presented token is hashed and compared with
// every known hash in constant time (CRYPTO_memcmp, no early exit over the list), so the
// timing says nothing about which hash matched or how much of it did.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "gonio/daemon/config/config.hpp"

namespace gonio::daemon {

class Store;

// Who is calling, for role checks and the audit log.
struct Principal {
  std::string name;          // token name, "unix:uid=1000", "anonymous"
  Role role = Role::none;
  std::string transport;     // "unix", "tcp", "http", "ws"
};

// Lower-case hex SHA-256 of `text`.
std::string sha256_hex(std::string_view text);
// 32 random bytes (getrandom) as 64 hex characters.
std::string generate_token();

class Auth {
 public:
  Auth(std::vector<TokenEntry> configured, Store& store);

  // The principal for a bearer token, nullopt when no hash matches.
  std::optional<Principal> authenticate(std::string_view token, std::string_view transport) const;
  // The principal of the token called `name` (a verified client certificate's CN names it),
  // nullopt when there is none.
  std::optional<Principal> named(std::string_view name, std::string_view transport) const;

  // First start: when no admin token is configured or stored, creates one, stores its hash
  // and writes the token to `file` (mode 0600, owner only). Returns true when it wrote one.
  bool ensure_admin_token(const std::filesystem::path& file);

  // Tokens created over the API (auth.create_token): returns the token text once.
  std::string create(const std::string& name, Role role);
  bool revoke(const std::string& name);
  std::vector<TokenEntry> list() const;  // configured + stored (hashes)
  // Whether a principal still stands: a token's is, while a token of that name and role
  // exists (not revoked); a Unix peer's (name "unix:...") always is.
  bool still_valid(const Principal& p) const;

  void reload();  // re-reads the stored tokens

 private:
  std::vector<TokenEntry> configured_;
  Store& store_;
  mutable std::mutex mu_;
  std::vector<TokenEntry> stored_;
  std::atomic<std::uint64_t> revocations_{0};
};

}  // namespace gonio::daemon
