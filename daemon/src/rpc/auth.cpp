// Bearer-token authentication with hashed storage and constant-time comparison (auth.hpp).
#include "gonio/daemon/rpc/auth.hpp"

#include <fcntl.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>

#include <fmt/format.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>

#include "gonio/daemon/store/store.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {
namespace {

using Digest = std::array<unsigned char, 32>;

Digest sha256(std::string_view text) {
  Digest d{};
  unsigned int len = 0;
  if (EVP_Digest(text.data(), text.size(), d.data(), &len, EVP_sha256(), nullptr) != 1 ||
      len != d.size())
    throw Error(Errc::internal, "SHA-256 failed");
  return d;
}

std::string to_hex(const unsigned char* p, std::size_t n) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string s(2 * n, '0');
  for (std::size_t i = 0; i < n; ++i) {
    s[2 * i] = kHex[p[i] >> 4];
    s[2 * i + 1] = kHex[p[i] & 15];
  }
  return s;
}

// Hex → digest; a malformed hash becomes all zeros, which no SHA-256 output equals in practice.
Digest from_hex(const std::string& hex) {
  Digest d{};
  if (hex.size() != 64) return d;
  const auto nib = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    return -1;
  };
  for (std::size_t i = 0; i < 32; ++i) {
    const int hi = nib(hex[2 * i]), lo = nib(hex[2 * i + 1]);
    if (hi < 0 || lo < 0) return Digest{};
    d[i] = static_cast<unsigned char>(hi * 16 + lo);
  }
  return d;
}

}  // namespace

std::string sha256_hex(std::string_view text) {
  const auto d = sha256(text);
  return to_hex(d.data(), d.size());
}

std::string generate_token() {
  std::array<unsigned char, 32> buf{};
  std::size_t got = 0;
  while (got < buf.size()) {
    const auto n = getrandom(buf.data() + got, buf.size() - got, 0);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw Error(Errc::io_error, fmt::format("getrandom: {}", std::strerror(errno)));
    }
    got += static_cast<std::size_t>(n);
  }
  return to_hex(buf.data(), buf.size());
}

Auth::Auth(std::vector<TokenEntry> configured, Store& store)
    : configured_(std::move(configured)), store_(store) {
  reload();
}

void Auth::reload() {
  auto tokens = store_.tokens();
  std::lock_guard lock(mu_);
  stored_ = std::move(tokens);
}

std::optional<Principal> Auth::authenticate(std::string_view token,
                                            std::string_view transport) const {
  if (token.empty() || token.size() > 1024) return std::nullopt;
  const Digest presented = sha256(token);
  std::lock_guard lock(mu_);
  const TokenEntry* match = nullptr;
  // Visit every entry whatever matches, so the time depends only on the list's length.
  const auto visit = [&](const TokenEntry& e) {
    const Digest known = from_hex(e.sha256);
    const bool equal = CRYPTO_memcmp(known.data(), presented.data(), known.size()) == 0;
    if (equal && !match) match = &e;
  };
  for (const auto& e : configured_) visit(e);
  for (const auto& e : stored_) visit(e);
  if (!match) return std::nullopt;
  return Principal{match->name, match->role, std::string(transport)};
}

std::optional<Principal> Auth::named(std::string_view name, std::string_view transport) const {
  std::lock_guard lock(mu_);
  const auto same = [&](const TokenEntry& e) { return e.name == name; };
  for (const auto* list : {&configured_, &stored_})
    if (const auto it = std::ranges::find_if(*list, same); it != list->end())
      return Principal{it->name, it->role, std::string(transport)};
  return std::nullopt;
}

bool Auth::ensure_admin_token(const std::filesystem::path& file) {
  for (const auto& e : configured_)
    if (e.role == Role::admin) return false;
  {
    std::lock_guard lock(mu_);
    for (const auto& e : stored_)
      if (e.role == Role::admin) return false;
  }
  const std::string token = generate_token();
  // Write the file first (O_EXCL, 0600): if that fails, no hash is stored for a token
  // nobody can read.
  std::error_code ec;
  std::filesystem::remove(file, ec);
  const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0600);
  if (fd < 0)
    throw Error(Errc::io_error, fmt::format("cannot create {}: {}", file.string(),
                                            std::strerror(errno)));
  const std::string text = token + "\n";
  const bool ok = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size()) &&
                  ::fchmod(fd, 0600) == 0 && ::fsync(fd) == 0;
  ::close(fd);
  if (!ok) throw Error(Errc::io_error, fmt::format("cannot write {}", file.string()));
  store_.put_token(TokenEntry{"admin", Role::admin, sha256_hex(token)});
  reload();
  return true;
}

std::string Auth::create(const std::string& name, Role role) {
  for (const auto& e : configured_)
    if (e.name == name)
      throw Error::wrong_state("name", fmt::format("token '{}' is defined in the config file", name));
  const std::string token = generate_token();
  store_.put_token(TokenEntry{name, role, sha256_hex(token)});
  reload();
  return token;
}

bool Auth::revoke(const std::string& name) {
  const bool removed = store_.delete_token(name);
  if (removed) ++revocations_;
  reload();
  return removed;
}

bool Auth::still_valid(const Principal& p) const {
  // Asked before every call: free until a token has been revoked.
  if (revocations_.load(std::memory_order_relaxed) == 0 || p.name.starts_with("unix:")) return true;
  std::lock_guard lock(mu_);
  const auto same = [&](const TokenEntry& e) { return e.name == p.name && e.role == p.role; };
  return std::ranges::any_of(configured_, same) || std::ranges::any_of(stored_, same);
}

std::vector<TokenEntry> Auth::list() const {
  std::lock_guard lock(mu_);
  auto all = configured_;
  all.insert(all.end(), stored_.begin(), stored_.end());
  return all;
}

}  // namespace gonio::daemon
