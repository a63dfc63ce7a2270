// Backups that restore: gonioctl backup against a goniod measuring under client load, the
// copy checked with SQLite itself, restored by goniod --restore into a new state directory
// and resumed there; and what --restore refuses, touching nothing.
#include <sqlite3.h>

#include <atomic>

#include <fmt/format.h>

#include <gtest/gtest.h>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

// An SQLite file opened read-only, for the checks.
class Db {
 public:
  explicit Db(const fs::path& file) {
    if (sqlite3_open_v2(file.c_str(), &db_, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK)
      throw std::runtime_error("cannot open " + file.string());
  }
  ~Db() { sqlite3_close(db_); }
  Db(const Db&) = delete;
  Db& operator=(const Db&) = delete;
  // The first column of every row of `sql`, as text.
  std::vector<std::string> column(const std::string& sql) const {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr) != SQLITE_OK)
      throw std::runtime_error(sql + ": " + sqlite3_errmsg(db_));
    std::vector<std::string> out;
    while (sqlite3_step(st) == SQLITE_ROW) {
      const auto* t = sqlite3_column_text(st, 0);
      out.emplace_back(t ? reinterpret_cast<const char*>(t) : "");
    }
    sqlite3_finalize(st);
    return out;
  }
  std::string one(const std::string& sql) const {
    const auto rows = column(sql);
    return rows.empty() ? std::string("<no row>") : rows.front();
  }

 private:
  sqlite3* db_ = nullptr;
};

std::vector<std::string> listing(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

TEST(Backup, MidScanUnderLoadRestoresEveryAcknowledgedPointAndResumes) {
  TempDir dir;
  MockOptions o;
  o.time_scale = 0.05;
  const auto cfg = mock_config(o);
  const auto live = dir.path / "live";
  const auto copy = dir.path / "copies" / "nightly.db";
  fs::create_directories(copy.parent_path());
  std::int64_t id = 0;
  json acked;
  {
    Goniod g(live, cfg);
    auto c = g.unix_conn();
    id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:1"}}});  // 61 points
    submit(c, "tile", kTrueSample, json{{"grids", {"in=30;out=-20:20:5"}}});       // queued behind it
    ASSERT_TRUE(eventually([&] { return c.call("scan.get", json{{"scan", id}})["points_done"].get<int>() >= 8; }, 30s))
        << g.log_text();
    // Load: two clients reading pages of points and the status as fast as they are answered.
    std::atomic<bool> done{false};
    std::atomic<int> calls{0};
    std::vector<std::thread> load;
    for (int i = 0; i < 2; ++i)
      load.emplace_back([&] {
        auto lc = g.unix_conn();
        while (!done) {
          lc.call("scan.points", json{{"scan", id}, {"limit", 1000}});
          lc.call("instrument.status");
          ++calls;
        }
      });
    // Every point acknowledged (committed and served) before the backup begins.
    acked = c.call("scan.points", json{{"scan", id}, {"limit", 1000}})["points"];
    const auto r = run_program("gonioctl", {"--state-dir", live.string(), "--connect", g.uri("tcp://"), "--json",
                                         "backup", copy.string()});
    done = true;
    for (auto& t : load) t.join();
    ASSERT_EQ(r.code, 0) << r.out << g.log_text();
    const auto answer = json::parse(r.out);
    EXPECT_EQ(answer["file"], copy.string());
    EXPECT_EQ(answer["bytes"].get<std::uintmax_t>(), fs::file_size(copy));
    EXPECT_GT(calls.load(), 0);
    // The scan went on: it is still measuring (or done), not paused or failed by the copy.
    const auto sc = c.call("scan.get", json{{"scan", id}});
    EXPECT_TRUE(sc["state"] == "running" || sc["state"] == "completed") << sc.dump();
    EXPECT_FALSE(fs::exists(copy.string() + ".part"));
    // goniod keeps no copy once it has been read.
    for (const auto& name : listing(live)) EXPECT_FALSE(name.starts_with("backup-")) << name;
    g.stop(SIGKILL);
  }
  ASSERT_GE(acked.size(), 8u);
  {
    Db db(copy);
    EXPECT_EQ(db.one("PRAGMA integrity_check"), "ok");
    EXPECT_EQ(db.one("PRAGMA journal_mode"), "delete");  // one self-contained file
    EXPECT_EQ(db.one("PRAGMA auto_vacuum"), "2");
    const auto stored = db.column("SELECT data FROM points WHERE scan_id = " + std::to_string(id) + " ORDER BY idx");
    ASSERT_GE(stored.size(), acked.size());
    for (std::size_t i = 0; i < acked.size(); ++i) EXPECT_EQ(json::parse(stored[i]), acked[i]) << "point " << i;
  }
  const auto restored = dir.path / "restored";
  const auto r = run_program("goniod", {"--restore", copy.string(), "--state-dir", restored.string()});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("restored"), std::string::npos) << r.out;
  EXPECT_EQ(listing(restored), std::vector<std::string>{"goniod.db"});
  {
    Goniod g(restored, cfg);
    auto c = g.unix_conn();
    // The scan was running when the copy was made: it resumes at its next unmeasured point.
    const auto sc = wait_state(c, id, {"completed", "paused", "failed"}, 60s);
    ASSERT_EQ(sc["state"], "completed") << sc.dump() << g.log_text();
    const auto points = c.call("scan.points", json{{"scan", id}, {"limit", 1000}})["points"];
    ASSERT_EQ(points.size(), 61u);
    for (std::size_t i = 0; i < points.size(); ++i) EXPECT_EQ(points[i]["index"], i);
    for (std::size_t i = 0; i < acked.size(); ++i) EXPECT_EQ(points[i], acked[i]);
    EXPECT_EQ(g.stop(), 0);
  }
}

TEST(Backup, RestoreRefusesWhatIsNotAnEmptyDirectoryOrNotAGonioStoreTouchingNothing) {
  TempDir dir;
  // A real copy to restore, from a goniod with one finished scan.
  const auto copy = dir.path / "good.db";
  {
    Goniod g(dir.path / "live", mock_config({}));
    auto c = g.unix_conn();
    const auto id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:20"}}});
    ASSERT_EQ(wait_state(c, id, {"completed"})["state"], "completed");
    const auto r = run_program("gonioctl", {"--state-dir", (dir.path / "live").string(), "backup", copy.string()});
    ASSERT_EQ(r.code, 0) << r.out;
    EXPECT_NE(r.out.find("sha256"), std::string::npos) << r.out;
    // Only an admin may take one: a viewer's token is refused.
    const auto viewer = c.call("auth.create_token", json{{"name", "eve"}, {"role", "viewer"}})["token"];
    auto t = g.tcp_conn();
    t.call("auth.login", json{{"token", viewer}});
    const auto refused = t.request("backup.create");
    ASSERT_TRUE(refused.contains("error")) << refused.dump();
    EXPECT_EQ(refused["error"]["data"]["errc"], "forbidden");
    const auto unknown = c.request("backup.read", json{{"backup", "0123456789abcdef"}});
    ASSERT_TRUE(unknown.contains("error"));
    EXPECT_EQ(unknown["error"]["data"]["errc"], "not_found");

    // The nightly timer's command: a copy named by its time, then the rotation rule over the
    // copies already there (two weeks of January 2020, two copies on the 19th) and nothing else.
    const auto nightly = dir.path / "nightly";
    fs::create_directories(nightly);
    for (int day = 6; day <= 19; ++day)
      std::ofstream(nightly / fmt::format("goniod-2020-01-{:02}T023000Z.db", day)) << "old copy\n";
    std::ofstream(nightly / "goniod-2020-01-19T120000Z.db") << "old copy\n";
    std::ofstream(nightly / "README") << "not a copy\n";
    const auto rr = run_program("gonioctl", {"--state-dir", (dir.path / "live").string(), "backup", "--dir",
                                          nightly.string(), "--keep-daily", "3", "--keep-weekly", "3"});
    ASSERT_EQ(rr.code, 0) << rr.out;
    auto left = listing(nightly);
    ASSERT_EQ(left.size(), 5u) << rr.out;
    // Days: the new copy's, the 19th (its newer copy), the 18th; weeks: the new copy's, the
    // week of the 13th (its newest, the 19th), the week of the 6th (its newest, the 12th).
    EXPECT_EQ(left[0], "README");
    EXPECT_EQ(left[1], "goniod-2020-01-12T023000Z.db");
    EXPECT_EQ(left[2], "goniod-2020-01-18T023000Z.db");
    EXPECT_EQ(left[3], "goniod-2020-01-19T120000Z.db");
    EXPECT_TRUE(left[4].starts_with("goniod-20") && left[4].ends_with("Z.db")) << left[4];
    EXPECT_EQ(Db(nightly / left[4]).one("PRAGMA integrity_check"), "ok");
    EXPECT_NE(rr.out.find("removed " + (nightly / "goniod-2020-01-19T023000Z.db").string()), std::string::npos) << rr.out;
    EXPECT_EQ(run_program("gonioctl", {"--state-dir", (dir.path / "live").string(), "backup"}).code, 2);
  }

  // A state directory that is not empty: named, and left as it was.
  const auto busy = dir.path / "busy";
  fs::create_directories(busy);
  std::ofstream(busy / "notes.txt") << "keep me\n";
  auto r = run_program("goniod", {"--restore", copy.string(), "--state-dir", busy.string()});
  EXPECT_EQ(r.code, 3) << r.out;
  EXPECT_NE(r.out.find(busy.string() + " is not empty"), std::string::npos) << r.out;
  EXPECT_EQ(listing(busy), std::vector<std::string>{"notes.txt"});

  // Files that are not a gonio store, each named with what is wrong; no state dir made.
  const auto target = dir.path / "target";
  const auto refuse = [&](const fs::path& file, const std::string& why) {
    const auto rr = run_program("goniod", {"--restore", file.string(), "--state-dir", target.string()});
    EXPECT_EQ(rr.code, 2) << rr.out;
    EXPECT_NE(rr.out.find(file.string()), std::string::npos) << rr.out;
    EXPECT_NE(rr.out.find(why), std::string::npos) << rr.out;
    EXPECT_FALSE(fs::exists(target)) << rr.out;
  };
  std::ofstream(dir.path / "notes.db") << "these are not the bytes of a database\n";
  refuse(dir.path / "notes.db", "not an SQLite database");
  refuse(dir.path / "missing.db", "does not exist");
  const auto make_db = [&](const std::string& name, const std::string& sql) {
    sqlite3* db = nullptr;
    sqlite3_open((dir.path / name).c_str(), &db);
    sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr);
    sqlite3_close(db);
    return dir.path / name;
  };
  refuse(make_db("other.db", "CREATE TABLE recipes(name TEXT);"), "no gonio schema version");
  refuse(make_db("newer.db", "CREATE TABLE t(x); PRAGMA user_version = 99;"), "schema version 99, newer");
  refuse(make_db("alien.db", "CREATE TABLE t(x); PRAGMA user_version = 3;"), "not the gonio tables");
  {  // a copy cut short: SQLite's own check finds it
    std::ifstream in(copy, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir.path / "cut.db", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  refuse(dir.path / "cut.db", "is not a gonio store");

  // The good copy into a directory that exists and is empty.
  const auto empty = dir.path / "empty";
  fs::create_directories(empty);
  r = run_program("goniod", {"--restore", copy.string(), "--state-dir", empty.string()});
  ASSERT_EQ(r.code, 0) << r.out;
  Db db(empty / "goniod.db");
  EXPECT_EQ(db.one("PRAGMA integrity_check"), "ok");
  EXPECT_EQ(db.one("SELECT COUNT(*) FROM points"), "4");
}

}  // namespace
}  // namespace gonio::test
