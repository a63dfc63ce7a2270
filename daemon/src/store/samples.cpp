// Store — samples (store.hpp).
#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "store/sqlite.hpp"

namespace gonio::daemon {

using nlohmann::json;

namespace {

constexpr const char* kSampleColumns = "id, name, notes, bsdf, tolerance, created_at, model_u, catalogue";

Sample read_sample(const db::Stmt& s) {
  Sample x;
  x.id = s.i64(0);
  x.spec.name = s.text(1);
  x.spec.notes = s.text(2);
  x.spec.bsdf = s.opt_text(3);
  x.spec.tolerance = s.f64(4);
  x.created_at = s.text(5);
  x.spec.model_u = s.f64(6);
  x.catalogue = s.opt_text(7).value_or("");
  return x;
}

}  // namespace

Sample Store::create_sample(const SampleSpec& spec, const std::string& actor,
                             const std::string& catalogue) {
  spec.validate("");
  std::lock_guard lock(write_mu_);
  db::Transaction t(*writer_);
  if (db::query_one(*writer_, "SELECT 1 FROM samples WHERE name = ?",
                    [](const db::Stmt&) { return true; }, spec.name))
    throw Error::exists("name", fmt::format("a sample named '{}'", spec.name));
  Sample out;
  out.spec = spec;
  out.created_at = utc::now();
  out.catalogue = catalogue;
  db::execute(*writer_,
              "INSERT INTO samples(name, notes, bsdf, tolerance, created_at, model_u, catalogue) "
              "VALUES (?,?,?,?,?,?,?)",
              spec.name, spec.notes, spec.bsdf, spec.tolerance, out.created_at, spec.model_u,
              catalogue.empty() ? std::optional<std::string>() : std::optional<std::string>(catalogue));
  out.id = writer_->last_insert_id();
  db::audit_in(*writer_, actor, "sample.create", fmt::format("sample:{}", out.id), json(spec));
  outbox_in(OutboxRow::Kind::sample, out.id, 0);
  t.commit();
  outbox_written();
  return out;
}

std::optional<Sample> Store::sample(std::int64_t id) const {
  auto c = read();
  return db::query_one(*c, fmt::format("SELECT {} FROM samples WHERE id = ?", kSampleColumns),
                       read_sample, id);
}

std::optional<Sample> Store::sample_by_name(const std::string& name) const {
  auto c = read();
  return db::query_one(*c, fmt::format("SELECT {} FROM samples WHERE name = ?", kSampleColumns),
                       read_sample, name);
}

std::vector<Sample> Store::samples(std::size_t offset, std::size_t limit) const {
  auto c = read();
  return db::query(
      *c, fmt::format("SELECT {} FROM samples ORDER BY id LIMIT ? OFFSET ?", kSampleColumns),
      read_sample, limit, offset);
}

}  // namespace gonio::daemon
