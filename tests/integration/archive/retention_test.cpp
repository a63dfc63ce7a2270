// Retention against a real archive: store.retention_days prunes a finished scan's points once
// PostgreSQL holds every one of them, never while they wait in the outbox; the scan, its
// verdict and counters stay, and its points are refused saying why. Skipped where PostgreSQL
// is not installed.
#include <gtest/gtest.h>

#include "gonio/test/archive_servers.hpp"

namespace gonio::test {
namespace {

bool postgres_installed() { return fs::exists(kPgBin + "/initdb") && run("command -v psql").first == 0; }

TEST(Retention, PrunesWhatTheArchiveCommittedAndNeverWhatWaitsInTheOutbox) {
  if (!postgres_installed()) GTEST_SKIP() << "PostgreSQL 15 not installed";
  TempDir dir;
  Postgres pg(dir.path / "pg");
  MockOptions o;
  o.tcp = o.http = false;
  // 0.00002 days: 1.7 s, checked every second.
  o.extra = "[archive]\npostgres = \"" + pg.conninfo() + "\"\ninstrument = \"kept\"\nretry_max_s = 0.2\n\n"
            "[store]\nretention_days = 0.00002\n";
  Goniod g(dir.path / "kept", mock_config(o));
  auto c = g.unix_conn();
  const auto pruned_at = [&](std::int64_t id) { return c.call("scan.get", json{{"scan", id}})["points_pruned_at"]; };

  const auto shipped = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:5"}}});  // 13 points
  ASSERT_EQ(wait_state(c, shipped, {"completed"})["state"], "completed");
  ASSERT_TRUE(eventually([&] { return !pruned_at(shipped).is_null(); }, 30s))
      << c.call("archive.status").dump() << g.log_text();
  EXPECT_EQ(pg.query("SELECT count(*) FROM points WHERE instrument = 'kept'"), "13\n");

  // The scan stays with its counters and verdict; its points are refused, saying why.
  const auto sc = c.call("scan.get", json{{"scan", shipped}});
  EXPECT_EQ(sc["points_done"], 13);
  EXPECT_EQ(sc["state"], "completed");
  EXPECT_FALSE(sc["verdict"].is_null());
  for (const auto& [method, params] : {std::pair<std::string, json>{"scan.points", json{{"scan", shipped}}},
                                       {"scan.export", json{{"scan", shipped}, {"format", "csv"}}}}) {
    const auto r = c.request(method, params);
    ASSERT_TRUE(r.contains("error")) << method << ": " << r.dump();
    EXPECT_EQ(r["error"]["data"]["errc"], "not_found") << r.dump();
    EXPECT_NE(r["error"]["message"].get<std::string>().find("pruned"), std::string::npos) << r.dump();
  }

  // With the archive down, a finished scan's points wait in the outbox and stay, however old.
  pg.stop();
  const auto waiting = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:10"}}});  // 7 points
  ASSERT_EQ(wait_state(c, waiting, {"completed"})["state"], "completed");
  std::this_thread::sleep_for(4s);  // past the retention, and past several of the keeper's passes
  EXPECT_TRUE(pruned_at(waiting).is_null());
  EXPECT_EQ(c.call("scan.points", json{{"scan", waiting}})["points"].size(), 7u);
  EXPECT_GT(c.call("archive.status")["backlog"].get<int>(), 0);

  // Once the archive has them, they go too.
  pg.start();
  ASSERT_TRUE(eventually([&] { return !pruned_at(waiting).is_null(); }, 30s))
      << c.call("archive.status").dump() << g.log_text();
  EXPECT_EQ(pg.query("SELECT count(*) FROM points WHERE instrument = 'kept'"), "20\n");
  bool audited = false;
  for (const auto& e : c.call("system.audit", json{{"limit", 1000}})) audited = audited || e["action"] == "store.prune";
  EXPECT_TRUE(audited);
}

}  // namespace
}  // namespace gonio::test
