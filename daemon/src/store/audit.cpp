// Store — the audit log: who did what, when (store.hpp).
#include "store/sqlite.hpp"

namespace gonio::daemon {

using nlohmann::json;

namespace db {

void audit_in(Connection& c, const std::string& actor, const std::string& action,
              const std::string& target, const json& detail) {
  execute(c, "INSERT INTO audit(at, actor, action, target, detail) VALUES (?, ?, ?, ?, ?)",
          utc::now(), actor, action, target, detail.dump());
}

}  // namespace db

void Store::audit(const std::string& actor, const std::string& action, const std::string& target,
                  const json& detail) {
  std::lock_guard lock(write_mu_);
  writer_->begin_write();
  db::audit_in(*writer_, actor, action, target, detail);
  writer_->committed();
}

std::vector<AuditEvent> Store::audit_events(std::size_t offset, std::size_t limit) const {
  auto c = read();
  return db::query(
      *c, "SELECT id, at, actor, action, target, detail FROM audit ORDER BY id DESC LIMIT ? OFFSET ?",
      [](const db::Stmt& s) {
        AuditEvent e;
        e.id = s.i64(0);
        e.at = s.text(1);
        e.actor = s.text(2);
        e.action = s.text(3);
        e.target = s.text(4);
        e.detail = json::parse(s.text(5), nullptr, false);
        return e;
      },
      limit, offset);
}

}  // namespace gonio::daemon
