// gonio-store-bench — the store's figures for daemon/README.md, through the store's own API
// on real SQLite files (a benchmark: it measures and prints, it asserts nothing).
//
//   gonio-store-bench backup [--points 100000] [--per-scan 500] [--dir DIR]
//       builds a store of that many points (31-channel spectra, measured and predicted, as a
//       visible scan stores them), then copies it with Store::backup_to while a writer keeps
//       committing points, and restores the copy: the copy's time and size, the writer's
//       longest commit during the copy and without one, the restore's time.
//   gonio-store-bench soak [--scans 20000] [--per-scan 20] [--keep 500] [--every 1000] [--no-retention]
//       scans measured one after the other with the archive outbox on; after each, its rows
//       leave the outbox as the archive shipper removes them once PostgreSQL has committed
//       them (Store::outbox_batch + outbox_remove), and retention prunes every scan that
//       finished before the last `keep` (Store::prune_archived, as store.retention_days
//       does with a time): the store's size every `every` scans.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/store/store.hpp"

namespace {

using namespace gonio;
using namespace gonio::daemon;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

double mib(std::uintmax_t bytes) { return static_cast<double>(bytes) / (1 << 20); }

// The store's files on disk: the database and its WAL.
std::uintmax_t on_disk(const fs::path& db) {
  std::error_code ec;
  std::uintmax_t n = fs::file_size(db, ec);
  const auto wal = fs::file_size(db.string() + "-wal", ec);
  return ec ? n : n + wal;
}

PointRecord make_point(std::int64_t scan, std::int64_t index) {
  std::vector<double> wl, v, u;
  for (int c = 0; c < 31; ++c) {
    wl.push_back(400 + 10 * c);
    v.push_back(0.05 + 0.001 * c + 1e-4 * static_cast<double>(index % 97));
    u.push_back(0.0005 + 1e-6 * c);
  }
  PointRecord p;
  p.scan_id = scan;
  p.index = index;
  p.geometry_index = index;
  p.planned = p.actual = Geometry::in_plane(45, -30 + 0.1 * static_cast<double>(index % 600));
  p.started_at = p.finished_at = utc::now();
  p.measured = Spectrum(WavelengthGrid(wl), v, u);
  p.predicted = Spectrum(WavelengthGrid(wl), v, u);
  p.z_max = 0.8;
  p.delta_e00 = 0.4;
  p.integration_ms = 100;
  return p;
}

ScanPlan make_plan(std::int64_t sample, std::size_t n) {
  ScanPlan p;
  p.sample_id = sample;
  for (std::size_t i = 0; i < n; ++i)
    p.geometries.push_back(Geometry::in_plane(45, -30 + 0.1 * static_cast<double>(i % 600)));
  return p;
}

// One scan measured to the end: `n` points, then completed with its verdict.
std::int64_t measure_scan(Store& s, std::int64_t sample, std::size_t n) {
  const auto sc = s.insert_scan(make_plan(sample, n), true, "bench");
  s.set_scan_state(sc.id, ScanState::running, "", "bench");
  for (std::size_t i = 0; i < n; ++i) s.insert_point(make_point(sc.id, static_cast<std::int64_t>(i)));
  s.set_scan_state(sc.id, ScanState::completed, "", "bench");
  s.insert_fit(sc.id, FitKind::verdict, "", nlohmann::json{{"consistent", true}}, "goniod");
  return sc.id;
}

std::int64_t make_sample(Store& s) {
  SampleSpec spec;
  spec.name = "tile";
  return s.create_sample(spec, "bench").id;
}

fs::path fresh_dir(const std::string& dir, const char* what) {
  fs::path d = dir.empty() ? fs::temp_directory_path() / fmt::format("gonio-store-bench-{}-{}", what, ::getpid()) : fs::path(dir);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// The longest of the writer's commits while `during` runs (or for `alone` if it is empty).
struct Writer {
  Store& store;
  std::int64_t scan;
  std::atomic<bool> stop{false};
  std::atomic<std::int64_t> next{0};
  double longest = 0;
  std::size_t commits = 0;
  void run() {
    while (!stop) {
      const auto t0 = Clock::now();
      store.insert_point(make_point(scan, next++));
      longest = std::max(longest, seconds_since(t0));
      ++commits;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));  // a fast scan's pace
    }
  }
};

int backup(std::size_t points, std::size_t per_scan, const std::string& dir_opt) {
  const auto dir = fresh_dir(dir_opt, "backup");
  const auto db = dir / "state" / "goniod.db";
  fs::create_directories(db.parent_path());
  {
    Store s(db, false);  // synchronous = NORMAL while building: the figure is the copy's
    const auto sample = make_sample(s);
    const auto t0 = Clock::now();
    for (std::size_t done = 0; done < points; done += per_scan) measure_scan(s, sample, std::min(per_scan, points - done));
    fmt::print("built a store of {} points in {:.1f} s: {:.1f} MiB\n", points, seconds_since(t0), mib(on_disk(db)));
  }
  Store s(db);  // as goniod runs it: synchronous = FULL
  const auto running = s.insert_scan(make_plan(1, 20000), true, "bench");
  s.set_scan_state(running.id, ScanState::running, "", "bench");

  Writer alone{s, running.id};
  std::thread t([&] { alone.run(); });
  std::this_thread::sleep_for(std::chrono::seconds(2));
  alone.stop = true;
  t.join();

  Writer beside{s, running.id};
  beside.next = alone.next.load();
  std::thread w([&] { beside.run(); });
  const auto copy = dir / "copy.db";
  const auto info = s.backup_to(copy);
  beside.stop = true;
  w.join();
  fmt::print("backup: {:.2f} s, {:.1f} MiB, {} scans, {} points; the writer meanwhile: {} commits, the longest "
             "{:.1f} ms (alone: {} commits in 2 s, the longest {:.1f} ms)\n",
             info.seconds, mib(info.bytes), info.scans, info.points, beside.commits, 1e3 * beside.longest,
             alone.commits, 1e3 * alone.longest);

  const auto t0 = Clock::now();
  const auto restored = Store::restore(copy, dir / "restored");
  fmt::print("restore (integrity check and copy): {:.2f} s, {} points\n", seconds_since(t0), restored.points);
  if (dir_opt.empty()) fs::remove_all(dir);
  return 0;
}

int soak(std::size_t scans, std::size_t per_scan, std::size_t keep, std::size_t every, bool retention) {
  const auto dir = fresh_dir({}, "soak");
  const auto db = dir / "goniod.db";
  Store s(db, false);
  s.set_outbox(true);
  const auto sample = make_sample(s);
  std::vector<std::string> finished;  // finished_at of each scan, in order
  fmt::print("# {} scans of {} points, the archive acknowledging each, retention {}\n", scans, per_scan,
             retention ? fmt::format("of the last {} scans", keep) : std::string("off"));
  fmt::print("# scans  points_stored  MiB_on_disk(db+wal)  MiB_db  pruned_scans  seconds\n");
  const auto t0 = Clock::now();
  std::int64_t pruned = 0, pruned_points = 0;
  for (std::size_t k = 1; k <= scans; ++k) {
    const auto id = measure_scan(s, sample, per_scan);
    finished.push_back(*s.scan(id)->finished_at);
    // What the shipper does after PostgreSQL committed the batch.
    for (auto rows = s.outbox_batch(5000); !rows.empty(); rows = s.outbox_batch(5000))
      s.outbox_remove(rows.front().seq, rows.back().seq);
    // Every scan that finished no later than the one `keep` scans back ('~' sorts after any
    // time text, so that scan's own time is included).
    if (retention && k > keep) {
      const auto r = s.prune_archived(finished[k - keep - 1] + "~");
      pruned += r.scans;
      pruned_points += r.points;
    }
    if (k % every == 0 || k == scans) {
      std::error_code ec;
      fmt::print("{:7}  {:13}  {:19.1f}  {:6.1f}  {:12}  {:7.0f}\n", k,
                 static_cast<std::int64_t>(k * per_scan) - pruned_points, mib(on_disk(db)),
                 mib(fs::file_size(db, ec)), pruned, seconds_since(t0));
      std::fflush(stdout);
    }
  }
  fs::remove_all(dir);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"gonio-store-bench — the store's backup and retention figures"};
  app.require_subcommand(1);
  spdlog::set_level(spdlog::level::warn);
  std::size_t points = 100000, per_scan = 500, scans = 20000, soak_per_scan = 20, keep = 500, every = 1000;
  std::string dir;
  bool no_retention = false;
  auto* b = app.add_subcommand("backup", "the copy of a store of --points points, beside a writer");
  b->add_option("--points", points, "points in the store");
  b->add_option("--per-scan", per_scan, "points per scan");
  b->add_option("--dir", dir, "work here (kept) instead of a temporary directory (removed)");
  auto* k = app.add_subcommand("soak", "the store's size over many scans with retention");
  k->add_option("--scans", scans, "scans measured");
  k->add_option("--per-scan", soak_per_scan, "points per scan");
  k->add_option("--keep", keep, "retention: scans older than the last KEEP are pruned");
  k->add_option("--every", every, "print a line every N scans");
  k->add_flag("--no-retention", no_retention, "prune nothing (the size without retention)");
  CLI11_PARSE(app, argc, argv);
  if (*b) return backup(points, per_scan, dir);
  return soak(scans, soak_per_scan, keep, std::max<std::size_t>(1, every), !no_retention);
}
