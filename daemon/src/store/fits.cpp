// Store — the inverse twin's results per scan and the versioned instrument profiles
// (store.hpp).
#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "store/sqlite.hpp"

namespace gonio::daemon {

using nlohmann::json;

namespace {

constexpr const char* kFitColumns = "id, scan_id, kind, model, created_by, created_at, result";

StoredFit read_fit(const db::Stmt& s) {
  StoredFit f;
  f.id = s.i64(0);
  f.scan_id = s.i64(1);
  const auto kind = s.text(2);
  if (const auto k = from_text<FitKind>(kind)) {
    f.kind = *k;
  } else {
    throw Error(Errc::internal, fmt::format("store: fit {} has the unknown kind '{}'", f.id, kind));
  }
  f.model = s.text(3);
  f.created_by = s.text(4);
  f.created_at = s.text(5);
  try {
    f.result = json::parse(s.text(6));
  } catch (const std::exception& e) {
    throw Error(Errc::internal, fmt::format("store: fit {} is unreadable: {}", f.id, e.what()));
  }
  return f;
}

constexpr const char* kProfileColumns =
    "version, name, scan_id, fit_id, created_by, created_at, profile";

StoredProfile read_profile(const db::Stmt& s) {
  StoredProfile p;
  p.version = s.i64(0);
  p.name = s.text(1);
  p.scan_id = s.opt_i64(2);
  p.fit_id = s.opt_i64(3);
  p.created_by = s.text(4);
  p.created_at = s.text(5);
  try {
    p.profile = json::parse(s.text(6));
  } catch (const std::exception& e) {
    throw Error(Errc::internal,
                fmt::format("store: profile version {} is unreadable: {}", p.version, e.what()));
  }
  return p;
}

// The audit action a stored record of `kind` is logged as.
const char* fit_action(FitKind kind) {
  return kind == FitKind::calibrate   ? "instrument.calibrate"
         : kind == FitKind::diagnosis ? "divergence.diagnose"
         : kind == FitKind::verdict   ? "scan.verdict"
                                      : "scan.fit";
}

}  // namespace

StoredFit Store::insert_fit(std::int64_t scan_id, FitKind kind, const std::string& model,
                            const json& result, const std::string& actor) {
  StoredFit f;
  f.scan_id = scan_id;
  f.kind = kind;
  f.model = model;
  f.created_by = actor;
  f.created_at = utc::now();
  f.result = result;
  std::lock_guard lock(write_mu_);
  db::Transaction tx(*writer_);
  db::execute(*writer_,
              "INSERT INTO fits(scan_id, kind, model, created_by, created_at, result) "
              "VALUES (?, ?, ?, ?, ?, ?)",
              scan_id, std::string(to_text(kind)), model, actor, f.created_at, result.dump());
  f.id = writer_->last_insert_id();
  db::audit_in(*writer_, actor, fit_action(kind), fmt::format("scan:{}", scan_id),
               json{{"fit", f.id}, {"model", model}});
  tx.commit();
  return f;
}

std::vector<StoredFit> Store::fits(std::int64_t scan_id, std::size_t limit) const {
  auto c = read();
  return db::query(*c,
                   fmt::format("SELECT {} FROM fits WHERE scan_id = ? AND kind <> 'verdict' "
                               "ORDER BY id DESC LIMIT ?",
                               kFitColumns),
                   read_fit, scan_id, limit);
}

std::optional<StoredFit> Store::latest_fit(std::int64_t scan_id, FitKind kind) const {
  auto c = read();
  return db::query_one(
      *c,
      fmt::format("SELECT {} FROM fits WHERE scan_id = ? AND kind = ? ORDER BY id DESC LIMIT 1",
                  kFitColumns),
      read_fit, scan_id, std::string(to_text(kind)));
}

StoredProfile Store::insert_profile(const std::string& name, const json& profile,
                                    std::optional<std::int64_t> scan_id,
                                    std::optional<std::int64_t> fit_id, const std::string& actor) {
  StoredProfile p;
  p.name = name;
  p.scan_id = scan_id;
  p.fit_id = fit_id;
  p.created_by = actor;
  p.created_at = utc::now();
  p.profile = profile;
  std::lock_guard lock(write_mu_);
  db::Transaction tx(*writer_);
  p.version = db::query_one(*writer_, "SELECT COALESCE(MAX(version), 0) FROM profiles",
                            [](const db::Stmt& s) { return s.i64(0) + 1; })
                  .value_or(1);
  db::execute(*writer_,
              "INSERT INTO profiles(version, name, scan_id, fit_id, created_by, created_at, "
              "profile) VALUES (?, ?, ?, ?, ?, ?, ?)",
              p.version, name, scan_id, fit_id, actor, p.created_at, profile.dump());
  db::audit_in(*writer_, actor, "profile.create", fmt::format("profile:{}", p.version),
               json{{"name", name}, {"scan", scan_id ? json(*scan_id) : json(nullptr)}});
  tx.commit();
  return p;
}

std::optional<StoredProfile> Store::latest_profile() const {
  auto c = read();
  return db::query_one(
      *c, fmt::format("SELECT {} FROM profiles ORDER BY version DESC LIMIT 1", kProfileColumns),
      read_profile);
}

}  // namespace gonio::daemon
