// MQTT and central-archive benchmarks (issue targets, measured here, never asserted in tests):
//   - archive catch-up from a backlog, 31 channels (target ≥ 5,000 points/s), against a
//     PostgreSQL cluster the benchmark starts;
//   - building the upserts of a batch alone (the client's share of the catch-up);
//   - what publishing adds to the runner per point (target ≤ 0.2 ms): the hub tap's call into
//     the MQTT publisher, broker up and broker down;
//   - a 1,000-point mock scan with the broker and the database configured but down, against
//     the same scan with both up (target: the same speed), and with neither configured.
// Run: build/bench/bin/bench --benchmark_filter='Archive|Mqtt|MockScan'
// (needs mosquitto and PostgreSQL 15 installed, as by .ci/bootstrap --test; the server
// benchmarks are skipped without them).
#include <benchmark/benchmark.h>

#include <chrono>
#include <memory>

#include "gonio/test/archive_servers.hpp"
#include "gonio/daemon/fleet/archive.hpp"
#include "gonio/daemon/fleet/mqtt.hpp"
#include "gonio/daemon/store/store.hpp"
#include "gonio/proto/point.hpp"

namespace gonio::daemon {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

PointRecord bench_point(std::int64_t scan, std::int64_t index) {
  PointRecord p;
  p.scan_id = scan;
  p.index = index;
  p.geometry_index = index;
  p.planned = p.actual = Geometry::in_plane(45, -30 + 0.05 * static_cast<double>(index % 1800));
  p.started_at = p.finished_at = utc::now();
  std::vector<double> v(31), u(31);
  for (std::size_t i = 0; i < 31; ++i) {
    v[i] = 0.4 + 0.001 * static_cast<double>(i) + 1e-6 * static_cast<double>(index);
    u[i] = 0.002;
  }
  p.measured = Spectrum(WavelengthGrid::parse("400:700:10"), v, u);
  p.predicted = p.measured;
  p.twin_version = "profile=gcms4#1";
  p.z_max = 0.8;
  p.delta_e00 = 0.3;
  p.flags = {"reference_read"};
  return p;
}

test::Postgres& postgres() {
  static test::TempDir dir;
  static test::Postgres pg(dir.path / "pg");
  return pg;
}

void BM_ArchiveBatchBuild(benchmark::State& state) {
  ArchiveInput in;
  Sample sm;
  sm.id = 1;
  sm.spec = SampleSpec{"tile", "", std::nullopt, 0.02};
  sm.created_at = utc::now();
  in.samples.emplace(1, sm);
  Scan sc;
  sc.id = 1;
  sc.plan.sample_id = 1;
  sc.submitted_at = utc::now();
  in.scans.emplace(1, sc);
  for (std::int64_t i = 0; i < 500; ++i)
    in.rows.push_back({i + 1, OutboxRow::Kind::point, 1, i, utc::now(), nullptr, json(bench_point(1, i)).dump()});
  for (auto _ : state) benchmark::DoNotOptimize(build_archive_batch("bench", "0", in));
  state.SetItemsProcessed(state.iterations() * 500);
}
BENCHMARK(BM_ArchiveBatchBuild)->Unit(benchmark::kMillisecond);

// A store with `points` points in its outbox, then a shipper started on it: points/s until
// the outbox is empty (schema creation is not timed: a first connection before the clock).
void BM_ArchiveCatchUp(benchmark::State& state) {
  if (!test::servers_installed()) {
    state.SkipWithError("PostgreSQL 15 or mosquitto not installed");
    return;
  }
  const auto points = static_cast<std::int64_t>(state.range(0));
  static int run = 0;
  for (auto _ : state) {
    test::TempDir dir;
    Config::Archive cfg;
    cfg.postgres = postgres().conninfo();
    cfg.batch = static_cast<std::size_t>(state.range(1));
    const auto instrument = "bench-" + std::to_string(::getpid()) + "-" + std::to_string(++run);
    {
      // The backlog, written without an fsync per point (filling is not what is measured).
      Store fill(dir.path / "goniod.db", false);
      fill.set_outbox(true);
      const auto sample = fill.create_sample(SampleSpec{"tile", "", std::nullopt, 0.02}, "bench");
      ScanPlan plan;
      plan.sample_id = sample.id;
      for (std::int64_t g = 0; g < points / 100; ++g)
        plan.geometries.push_back(Geometry::in_plane(45, -30 + 0.4 * static_cast<double>(g % 200)));
      plan.repeats = 100;
      const auto sc = fill.insert_scan(plan, true, "bench");
      for (std::int64_t i = 0; i < points; ++i) fill.insert_point(bench_point(sc.id, i));
    }
    Store store(dir.path / "goniod.db", true);  // as goniod runs: synchronous = full
    {
      Store empty(dir.path / "warm.db", false);
      ArchiveShipper warm(cfg, instrument + "-warm", empty, nullptr);  // creates the schema
      warm.start();
      test::eventually([&] { return warm.status()["schema_version"].get<int>() > 0; }, std::chrono::seconds(30));
      warm.stop();
    }
    ArchiveShipper shipper(cfg, instrument, store, nullptr);
    const auto t0 = Clock::now();
    shipper.start();
    // The shipper's own count (refreshed after every batch): polling the store would compete
    // with it for the CPU.
    while (shipper.status()["backlog"].get<std::int64_t>() > 0 || shipper.status()["batches"] == 0)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    const auto dt = std::chrono::duration<double>(Clock::now() - t0).count();
    state.SetIterationTime(dt);
    state.counters["points_per_s"] = static_cast<double>(points) / dt;
    shipper.stop();
  }
  state.SetItemsProcessed(state.iterations() * points);
}
BENCHMARK(BM_ArchiveCatchUp)->Args({20000, 500})->Args({20000, 2000})->Iterations(3)->UseManualTime()->Unit(benchmark::kMillisecond);

// The runner's share of MQTT per point: route, copy and enqueue (the hub tap's call).
void BM_MqttPublishPerPoint(benchmark::State& state) {
  const bool broker_up = state.range(0) != 0;
  if (broker_up && !test::servers_installed()) {
    state.SkipWithError("mosquitto not installed");
    return;
  }
  test::TempDir dir;
  std::unique_ptr<test::Broker> broker;
  Config::Mqtt cfg;
  if (broker_up) {
    broker = std::make_unique<test::Broker>(dir.path / "mqtt");
    cfg.url = "mqtt://127.0.0.1:" + std::to_string(broker->port());
  } else {
    cfg.url = "mqtt://127.0.0.1:" + std::to_string(test::free_port());  // nobody listens
  }
  MqttPublisher pub(cfg, "bench", [] { return std::string(R"({"state":"idle"})"); });
  pub.start();
  if (broker_up) test::eventually([&] { return pub.status()["connected"].get<bool>(); }, std::chrono::seconds(10));
  const auto text = json(bench_point(1, 0)).dump();
  const auto progress = json{{"scan", 1}, {"state", "running"}, {"points_done", 1}, {"points_total", 1000}}.dump();
  for (auto _ : state) {
    pub.publish("scan.point", text, 1);        // what the runner publishes per point
    pub.publish("scan.progress", progress, 1);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["dropped"] = pub.status()["dropped"].get<double>();
  state.counters["payload_bytes"] = static_cast<double>(text.size());
  pub.stop();
}
BENCHMARK(BM_MqttPublishPerPoint)->Arg(1)->Arg(0)->Unit(benchmark::kMicrosecond);

// A 1,000-point scan of goniod --mock without motion time or predictions (so that the
// runner and the store are all there is to measure), from running to completed as goniod
// timed it. Arg 0: neither MQTT nor the archive configured; 1: both configured and both
// down (nothing listens there); 2: both configured and up. The target compares 1 with 2;
// 0 shows what the outbox and the publishing cost a scan at all.
void BM_MockScan1000(benchmark::State& state) {
  const auto mode = state.range(0);
  const bool configured = mode != 0;
  if (mode == 2 && !test::servers_installed()) {
    state.SkipWithError("PostgreSQL 15 or mosquitto not installed");
    return;
  }
  static int run = 0;
  for (auto _ : state) {
    test::TempDir dir;
    std::unique_ptr<test::Broker> broker;
    if (mode == 2) broker = std::make_unique<test::Broker>(dir.path / "mqtt");
    test::MockOptions o;
    o.tcp = o.http = false;
    const auto instrument = "bench-scan-" + std::to_string(::getpid()) + "-" + std::to_string(++run);
    if (mode == 1)
      o.extra = "[mqtt]\nurl = \"mqtt://127.0.0.1:" + std::to_string(test::free_port()) +
                "\"\ninstrument = \"bench\"\n\n[archive]\npostgres = \"host=" + dir.path.string() +
                " port=" + std::to_string(test::free_port()) + " dbname=none connect_timeout=2\"\n"
                "instrument = \"bench\"\n";
    if (mode == 2)
      o.extra = "[mqtt]\nurl = \"mqtt://127.0.0.1:" + std::to_string(broker->port()) +
                "\"\ninstrument = \"" + instrument + "\"\n\n[archive]\npostgres = \"" +
                postgres().conninfo() + "\"\ninstrument = \"" + instrument + "\"\n";
    test::Goniod g(dir.path / "state", test::mock_config(o));
    auto c = g.unix_conn();
    const auto id = test::submit(c, "tile", "", json{{"grids", {"in=45;out=-30:69:1"}}, {"repeats", 10}});
    const auto sc = test::wait_state(c, id, {"completed", "failed"}, std::chrono::seconds(600));
    if (sc["state"] != "completed" || sc["points_total"] != 1000) {
      state.SkipWithError("the scan did not complete with 1000 points");
      return;
    }
    const auto dt = std::chrono::duration<double>(utc::parse(sc["finished_at"].get<std::string>()) -
                                                  utc::parse(sc["started_at"].get<std::string>()))
                        .count();
    state.SetIterationTime(dt);
    state.counters["points_per_s"] = 1000.0 / dt;
    const auto info = c.call("system.info");
    state.counters["runner_overhead_ms_p50"] = info["runner"].value("overhead_ms_p50", 0.0);
    if (configured) state.counters["archive_backlog"] = info["archive"]["backlog"].get<double>();
  }
}
BENCHMARK(BM_MockScan1000)->Arg(0)->Arg(1)->Arg(2)->Iterations(2)->UseManualTime()->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace gonio::daemon
