// Power cuts, modelled: goniod runs under the power-cut shim (tests/support/src/powercut.cpp,
// LD_PRELOAD), which records how to undo every write to its state directory not yet made
// durable by fsync/fdatasync. At a random instant mid-scan goniod is killed and, per file,
// a random prefix of those writes is kept (none, half the time) and the rest undone; the
// WAL index (-shm) is deleted. Over 100 such cuts on one store: it passes
// PRAGMA integrity_check after each, every point acknowledged to a client (a scan.point
// notification, sent after the commit) before the cut is stored after it, the interrupted
// scan resumes, the archive outbox (written in each point's transaction; the archive never
// answers here) still owes every such point, and at the end every scan is complete with each
// point once. With
// store.synchronous = normal the same harness measures what a cut may take (the loss window).
#include <sqlite3.h>
#include <sys/types.h>

#include <cstdio>
#include <map>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

const fs::path kShim = fs::path(GONIO_BINARY_DIR) / "tests" / "libgonio_powercut.so";

// Undoes, per file, the unsynced writes after a random prefix of them (powercut.cpp).
// Returns the number of writes undone.
std::size_t cut_power(const fs::path& dir, std::mt19937_64& rng) {
  std::size_t undone = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    const auto p = e.path();
    if (p.extension() != ".powercut-undo") continue;
    const fs::path target = p.parent_path() / p.stem();
    struct Rec {
      std::int64_t offset, size;
      std::string old;
    };
    std::vector<Rec> recs;
    {
      std::ifstream in(p, std::ios::binary);
      std::int64_t head[3];
      while (in.read(reinterpret_cast<char*>(head), sizeof head)) {
        Rec r{head[0], head[1], std::string(static_cast<std::size_t>(head[2]), '\0')};
        if (head[2] > 0 && !in.read(r.old.data(), head[2])) break;  // a torn record: its write never happened
        recs.push_back(std::move(r));
      }
    }
    std::size_t keep = 0;
    if (!recs.empty() && std::bernoulli_distribution(0.5)(rng))
      keep = std::uniform_int_distribution<std::size_t>(0, recs.size())(rng);
    if (fs::exists(target) && keep < recs.size()) {
      std::fstream f(target, std::ios::in | std::ios::out | std::ios::binary);
      for (std::size_t i = recs.size(); i-- > keep;) {
        f.seekp(recs[i].offset);
        f.write(recs[i].old.data(), static_cast<std::streamsize>(recs[i].old.size()));
        f.flush();
        fs::resize_file(target, static_cast<std::uintmax_t>(recs[i].size));
        ++undone;
      }
    }
    fs::resize_file(p, 0);
  }
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().string().ends_with("-shm")) fs::remove(e.path());
  return undone;
}

std::string integrity(const fs::path& db) {
  sqlite3* h = nullptr;
  std::string out = "cannot open";
  if (sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(h, "PRAGMA integrity_check", -1, &st, nullptr) == SQLITE_OK) {
      out.clear();
      while (sqlite3_step(st) == SQLITE_ROW) out += reinterpret_cast<const char*>(sqlite3_column_text(st, 0));
    } else {
      out = sqlite3_errmsg(h);
    }
    sqlite3_finalize(st);
  }
  sqlite3_close(h);
  return out;
}

// The stored point indices of a scan (none when the scan itself is gone).
// The (scan, point) pairs the archive outbox owes the archive.
std::set<std::pair<std::int64_t, std::int64_t>> outbox_points(const fs::path& db) {
  std::set<std::pair<std::int64_t, std::int64_t>> out;
  sqlite3* h = nullptr;
  if (sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(h, "SELECT ref, idx FROM outbox WHERE kind = 'point'", -1, &st, nullptr) == SQLITE_OK)
      while (sqlite3_step(st) == SQLITE_ROW) out.emplace(sqlite3_column_int64(st, 0), sqlite3_column_int64(st, 1));
    sqlite3_finalize(st);
  }
  sqlite3_close(h);
  return out;
}

std::set<std::int64_t> stored(Conn& c, std::int64_t scan) {
  std::set<std::int64_t> idx;
  for (int offset = 0;; offset += 200) {
    const auto r = c.request("scan.points", json{{"scan", scan}, {"offset", offset}, {"limit", 200}});
    if (r.contains("error")) return idx;
    const auto& page = r["result"]["points"];
    if (page.empty()) return idx;
    for (const auto& p : page) EXPECT_TRUE(idx.insert(p["index"].get<std::int64_t>()).second) << "stored twice";
  }
}

struct CutStats {
  int cuts = 0;
  std::size_t acknowledged = 0, lost = 0, undone = 0, corrupt = 0;
  std::size_t worst_loss = 0;
  std::size_t scans_lost = 0;  // submitted, acknowledged and gone
};

// `cuts` power cuts mid-scan on one state directory; the store's synchronous mode as given.
CutStats run_cuts(const fs::path& dir, int cuts, const std::string& synchronous, std::uint64_t seed) {
  CutStats s;
  std::mt19937_64 rng(seed);
  const auto state = dir / "state";
  fs::create_directories(state);
  MockOptions o;
  o.tcp = o.http = false;
  // An archive that never answers: every point also writes an outbox row, in its transaction.
  o.extra = "[store]\nsynchronous = \"" + synchronous + "\"\nmin_free_mb = 0\n\n[archive]\n"
            "postgres = \"postgresql://gonio@127.0.0.1:1/none\"\nretry_max_s = 5\n";
  const auto config = mock_config(o);
  const std::vector<std::string> env{"LD_PRELOAD=" + kShim.string(), "POWERCUT_DIR=" + state.string()};
  std::map<std::int64_t, std::set<std::int64_t>> acked;  // scan -> acknowledged points
  for (int cut = 0; cut < cuts; ++cut) {
    Goniod g(state, config, env);
    auto c = g.unix_conn();
    for (const auto& [scan, points] : acked) {
      if (c.request("scan.get", json{{"scan", scan}}).contains("error")) ++s.scans_lost;
      const auto have = stored(c, scan);
      std::size_t lost = 0;
      for (const auto i : points) lost += !have.contains(i);
      s.lost += lost;
      s.worst_loss = std::max(s.worst_loss, lost);
      if (synchronous == "full") {
        EXPECT_EQ(lost, 0u) << "scan " << scan << " after cut " << cut;
      }
      // What was lost is measured again: it is no longer acknowledged.
      std::set<std::int64_t> kept;
      for (const auto i : points)
        if (have.contains(i)) kept.insert(i);
      acked[scan] = kept;
    }
    c.call("subscribe", json{{"topics", {"points"}}});
    // A scan to cut: the interrupted one resumes by itself; else a new one.
    bool active = false;
    for (const auto& sc : c.call("scan.list", json{{"limit", 100}}))
      if (sc["state"] == "running" || sc["state"] == "queued" || sc["state"] == "interrupted") active = true;
    // Without a catalogued BSDF (no predictions to compute at each start): the cuts are
    // about the store, and a start costs little.
    if (!active) submit(c, "plate", "", json{{"grids", {"in=45;out=-5:85:1"}}});  // 91 points
    // Cut after a random number of acknowledged points, a random moment after the last.
    const int wait_points = std::uniform_int_distribution<int>(1, 8)(rng);
    for (int n = 0; n < wait_points;) {
      const auto note = c.notification(3s);
      if (!note) break;  // the scan ended: cut the idle daemon
      if ((*note)["method"] != "scan.point") continue;
      s.acknowledged += acked[(*note)["params"]["scan_id"].get<std::int64_t>()]
                            .insert((*note)["params"]["index"].get<std::int64_t>())
                            .second;
      ++n;
    }
    std::this_thread::sleep_for(std::chrono::microseconds(std::uniform_int_distribution<int>(0, 3000)(rng)));
    g.stop(SIGKILL);
    // Notifications that left before the kill were acknowledged too.
    while (auto note = c.notification(50ms))
      if ((*note)["method"] == "scan.point")
        s.acknowledged += acked[(*note)["params"]["scan_id"].get<std::int64_t>()]
                              .insert((*note)["params"]["index"].get<std::int64_t>())
                              .second;
    s.undone += cut_power(state, rng);
    ++s.cuts;
    const auto check = integrity(state / "goniod.db");
    if (check != "ok") ++s.corrupt;
    EXPECT_EQ(check, "ok") << "after cut " << cut;
    if (synchronous == "full") {
      // Nothing acknowledged has left the archive's outbox either.
      const auto owed = outbox_points(state / "goniod.db");
      for (const auto& [scan, points] : acked)
        for (const auto i : points) EXPECT_TRUE(owed.contains({scan, i})) << "outbox: scan " << scan << " point " << i;
    }
  }
  // The last cut's scan resumes and every scan completes with each point once.
  Goniod g(state, config, env);
  auto c = g.unix_conn();
  for (const auto& sc : c.call("scan.list", json{{"limit", 100}})) {
    const auto id = sc["id"].get<std::int64_t>();
    EXPECT_EQ(wait_state(c, id, {"completed", "paused", "failed"}, 60s)["state"], "completed") << g.log_text();
    const auto have = stored(c, id);
    EXPECT_EQ(have.size(), 91u);
    if (!have.empty()) {
      EXPECT_EQ(*have.rbegin(), 90);
    }
  }
  return s;
}

TEST(PowerCut, HundredCutsMidScanLoseNoAcknowledgedPointAndLeaveNoCorruptStore) {
  ASSERT_TRUE(fs::exists(kShim)) << kShim;
  TempDir dir;
  const auto s = run_cuts(dir.path, 100, "full", 24);
  EXPECT_EQ(s.cuts, 100);
  EXPECT_EQ(s.corrupt, 0u);
  EXPECT_EQ(s.lost, 0u);
  EXPECT_GT(s.undone, 0u) << "the cuts must have dropped unsynced writes";
  EXPECT_EQ(s.scans_lost, 0u);
  std::printf("synchronous = full: %d cuts, %zu unsynced writes dropped, %zu acknowledged points, %zu lost\n",
              s.cuts, s.undone, s.acknowledged, s.lost);
}

// synchronous = normal: the WAL is not synced at each commit, so a cut may take committed and
// acknowledged points with it (those since the last checkpoint's sync). The store must
// still be intact and the scans complete; the figures are the documented loss window.
TEST(PowerCut, WithSynchronousNormalTheStoreSurvivesAndTheLossWindowIsMeasured) {
  ASSERT_TRUE(fs::exists(kShim)) << kShim;
  TempDir dir;
  const auto s = run_cuts(dir.path, 20, "normal", 7);
  EXPECT_EQ(s.corrupt, 0u);
  std::printf("synchronous = normal: %d cuts, %zu acknowledged points, %zu lost (worst cut: %zu), "
              "%zu acknowledged scans gone\n",
              s.cuts, s.acknowledged, s.lost, s.worst_loss, s.scans_lost);
}

}  // namespace
}  // namespace gonio::test
