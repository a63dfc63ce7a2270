// Disk full is a pause, not a crash: goniod with its state directory on a real, small file
// system (a tmpfs mounted with a size limit) that fills up mid-scan pauses the scan with a
// storage alert, serves reads, refuses writes with storage_unavailable (−32011), and after
// the space is freed and a technician resumes, completes the scan with every point once;
// it starts on a full disk read-only; a low-space watermark keeps new scans from starting.
// Mounting needs root (CAP_SYS_ADMIN): without it the tmpfs tests skip and say so.
#include <sys/mount.h>
#include <unistd.h>

#include <fstream>

#include <gtest/gtest.h>

#include "gonio/test/daemon_harness.hpp"

namespace gonio::test {
namespace {

constexpr int kStorageUnavailable = -32011;

// A tmpfs of `size` mounted on a fresh directory; unmounted (lazily) at the end.
class SmallFs {
 public:
  explicit SmallFs(const fs::path& at, const std::string& size) : path(at) {
    fs::create_directories(at);
    const auto opts = "size=" + size + ",mode=0700";
    mounted = ::mount("tmpfs", at.c_str(), "tmpfs", 0, opts.c_str()) == 0;
  }
  ~SmallFs() {
    if (mounted) ::umount2(path.c_str(), MNT_DETACH);
  }
  SmallFs(const SmallFs&) = delete;
  SmallFs& operator=(const SmallFs&) = delete;

  // Writes zeros to `file` until the file system is full, or until `leave` bytes are free.
  void fill(const fs::path& file, std::uintmax_t leave = 0) const {
    std::ofstream out(file, std::ios::binary);
    const std::string block(4096, '\0');
    while (fs::space(path).available > leave + block.size() && out.write(block.data(), block.size())) out.flush();
    if (leave == 0)
      while (out.write(block.data(), 1)) out.flush();  // the last bytes, one at a time
  }

  fs::path path;
  bool mounted = false;
};

json all_points(Conn& c, std::int64_t scan) {
  json all = json::array();
  for (int offset = 0;; offset += 100) {
    const auto page = c.call("scan.points", json{{"scan", scan}, {"offset", offset}, {"limit", 100}})["points"];
    if (page.empty()) return all;
    for (const auto& p : page) all.push_back(p);
  }
}

std::string storage_config(const std::string& store) {
  MockOptions o;
  o.extra = "[store]\n" + store;
  return mock_config(o);
}

TEST(Storage, DiskFullMidScanPausesServesReadsAndResumesWithNothingLostOrTwice) {
  TempDir dir;
  SmallFs small(dir.path / "fs", "16m");
  if (!small.mounted) GTEST_SKIP() << "cannot mount a tmpfs here (needs root)";
  Goniod g(small.path / "state", storage_config("min_free_mb = 0\n"));
  auto c = g.unix_conn();
  // Room for a few dozen points: the scan itself fills the disk.
  small.fill(small.path / "filler", 256 << 10);
  const auto id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-5:85:1"}}});  // 91 points
  const auto paused = wait_state(c, id, {"paused", "completed", "failed"}, 60s);
  ASSERT_EQ(paused["state"], "paused") << paused.dump() << g.log_text();
  const auto reason = paused["reason"].get<std::string>();
  EXPECT_NE(reason.find("storage"), std::string::npos) << reason;
  EXPECT_NE(reason.find("MiB free"), std::string::npos) << reason;
  const auto done_before = paused["points_done"].get<std::size_t>();
  EXPECT_GT(done_before, 0u);
  EXPECT_LT(done_before, 91u);

  // goniod is up; reads are served, writes refused with the storage code.
  const auto alerts = c.call("alert.list", json{{"limit", 100}});
  bool storage_alert = false;
  for (const auto& a : alerts)
    if (a["kind"] == "storage" && a["severity"] == "critical") {
      storage_alert = true;
      EXPECT_NE(a["message"].get<std::string>().find((small.path / "state").string()), std::string::npos) << a.dump();
    }
  EXPECT_TRUE(storage_alert) << alerts.dump();
  EXPECT_EQ(all_points(c, id).size(), done_before);
  const auto st = c.call("instrument.status")["storage"];
  EXPECT_EQ(st["writable"], false) << st.dump();
  const auto refused = c.request("sample.create", json{{"name", "another"}});
  ASSERT_TRUE(refused.contains("error")) << refused.dump();
  EXPECT_EQ(refused["error"]["code"], kStorageUnavailable);
  EXPECT_EQ(refused["error"]["data"]["errc"], "storage_unavailable");
  EXPECT_EQ(c.request("scan.resume", json{{"scan", id}})["error"]["code"], kStorageUnavailable);

  // Space back: the store writes again by itself; the technician resumes.
  fs::remove(small.path / "filler");
  ASSERT_TRUE(eventually([&] { return c.call("instrument.status")["storage"]["writable"].get<bool>(); }))
      << g.log_text();
  c.call("scan.resume", json{{"scan", id}});
  const auto done = wait_state(c, id, {"completed", "paused", "failed"}, 120s);
  ASSERT_EQ(done["state"], "completed") << done.dump() << g.log_text();
  const auto points = all_points(c, id);
  ASSERT_EQ(points.size(), 91u);
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_EQ(points[i]["index"], i);
  EXPECT_EQ(g.stop(), 0);
}

// Also the path where not even the alert can be written: the low-space warning raised on
// the full disk is published from memory (id 0) and stored once the space is back.
TEST(Storage, StartsReadOnlyOnAFullDiskAndWritesOnceSpaceIsBack) {
  TempDir dir;
  SmallFs small(dir.path / "fs", "8m");
  if (!small.mounted) GTEST_SKIP() << "cannot mount a tmpfs here (needs root)";
  std::int64_t id = 0;
  {
    Goniod g(small.path / "state", storage_config("min_free_mb = 0\n"));
    auto c = g.unix_conn();
    id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:10"}}});
    ASSERT_EQ(wait_state(c, id, {"completed", "paused", "failed"})["state"], "completed") << g.log_text();
    g.stop(SIGKILL);  // leaves the WAL and its index behind, as a crash would
  }
  small.fill(small.path / "filler");
  Goniod g(small.path / "state", storage_config("min_free_mb = 1\n"));  // throws if it exits
  auto c = g.unix_conn();
  json held;
  ASSERT_TRUE(eventually([&] {
    held = c.call("instrument.status")["storage"]["unsaved_alerts"];
    return !held.empty();
  })) << g.log_text();
  EXPECT_EQ(held[0]["kind"], "storage");
  EXPECT_EQ(held[0]["id"], 0);
  EXPECT_EQ(held[0]["severity"], "warning");
  EXPECT_EQ(c.call("scan.get", json{{"scan", id}})["state"], "completed");
  EXPECT_EQ(all_points(c, id).size(), 7u);
  const auto refused = c.request("scan.submit", json{{"sample", "tile"}, {"grids", {"in=45;out=0"}}});
  ASSERT_TRUE(refused.contains("error")) << refused.dump();
  EXPECT_EQ(refused["error"]["code"], kStorageUnavailable) << refused.dump();
  EXPECT_EQ(c.call("instrument.status")["storage"]["writable"], false);

  fs::remove(small.path / "filler");
  ASSERT_TRUE(eventually([&] { return c.call("instrument.status")["storage"]["writable"].get<bool>(); }))
      << g.log_text();
  ASSERT_TRUE(eventually([&] { return c.call("instrument.status")["storage"]["unsaved_alerts"].empty(); }));
  bool stored = false;
  for (const auto& a : c.call("alert.list", json{{"limit", 100}}))
    stored = stored || (a["kind"] == "storage" && a["id"].get<std::int64_t>() > 0);
  EXPECT_TRUE(stored);
  const auto id2 = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=0:20:10"}}});
  EXPECT_EQ(wait_state(c, id2, {"completed", "paused", "failed"})["state"], "completed") << g.log_text();
}

TEST(Storage, BelowTheLowSpaceWatermarkAWarningIsRaisedAndNoNewScanStarts) {
  TempDir dir;
  // More free space than any test machine has: the watermark is crossed from the start.
  Goniod g(dir.path, storage_config("min_free_mb = 1e7\n"));
  auto c = g.unix_conn();
  const auto id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=0"}}});
  json warning;
  ASSERT_TRUE(eventually([&] {
    for (const auto& a : c.call("alert.list", json{{"limit", 100}}))
      if (a["kind"] == "storage") warning = a;
    return !warning.is_null();
  })) << g.log_text();
  EXPECT_EQ(warning["severity"], "warning");
  EXPECT_NE(warning["message"].get<std::string>().find("no new scan starts"), std::string::npos) << warning.dump();
  EXPECT_EQ(c.call("scan.get", json{{"scan", id}})["state"], "queued");
  EXPECT_EQ(c.call("instrument.status")["storage"]["low"], true);
}

}  // namespace
}  // namespace gonio::test
