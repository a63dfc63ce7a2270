// Store — API-created tokens, as hashes only (store.hpp, auth.hpp).
#include <fmt/format.h>

#include "store/sqlite.hpp"

namespace gonio::daemon {

using nlohmann::json;

void Store::put_token(const TokenEntry& t) {
  std::lock_guard lock(write_mu_);
  db::Transaction tx(*writer_);
  db::execute(*writer_,
              "INSERT INTO tokens(name, role, sha256, created_at) VALUES (?, ?, ?, ?) "
              "ON CONFLICT(name) DO UPDATE SET role = excluded.role, sha256 = excluded.sha256, "
              "created_at = excluded.created_at",
              t.name, std::string(to_text(t.role)), t.sha256, utc::now());
  db::audit_in(*writer_, "goniod", "auth.token", fmt::format("token:{}", t.name),
               json{{"role", to_text(t.role)}});
  tx.commit();
}

bool Store::delete_token(const std::string& name) {
  std::lock_guard lock(write_mu_);
  writer_->begin_write();
  db::execute(*writer_, "DELETE FROM tokens WHERE name = ?", name);
  return writer_->changes() > 0;
}

std::vector<TokenEntry> Store::tokens() const {
  auto c = read();
  return db::query(*c, "SELECT name, role, sha256 FROM tokens ORDER BY name", [](const db::Stmt& s) {
    return TokenEntry{s.text(0), parse_role(s.text(1)), s.text(2)};
  });
}

}  // namespace gonio::daemon
