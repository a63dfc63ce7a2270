// Render benchmark (the target, measured here, never asserted in tests): a 512 px
// pair at the default quality — the virtual measurement on the default specular grid plus
// the true and the measured sphere to 1 % per-pixel relative s.e. — on two threads.
// Run: build/ci/bin/bench --benchmark_filter=Render
#include <benchmark/benchmark.h>

#include <chrono>
#include <ctime>

#include "gonio/twin/render.hpp"
#include "gonio/twin/virtual_measurement.hpp"

namespace gonio::twin {
namespace {

void BM_RenderPair(benchmark::State& state) {
  const auto grid = WavelengthGrid::parse("400:700:10");
  const Twin twin(InstrumentProfile{}, make_bsdf("conductor:alpha=0.05,eta=0.2,k=3.9", grid), grid);
  RenderOptions o;  // the defaults of gonio-twin render
  o.size = static_cast<int>(state.range(0));
  o.threads = 2;
  EstimatorOptions eo;  // gonio-twin render's measurement defaults
  eo.rel_se = 5e-3;
  eo.replicates = 16;
  eo.first_points = 32;
  double cpu_s = 0, measure_s = 0, true_s = 0, measured_s = 0, spp = 0, p95 = 0, de_mean = 0, de_p95 = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();
    TabulatedParts parts;
    parts.brdf = measure_specular(twin, specular_measurement_grid(5, 0.5, 15), eo, 2);
    const TabulatedBsdf measured(grid, std::move(parts), "measured");
    measure_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const auto r = render_comparison({&twin.sample(), &measured}, {"true", "measured"}, o);
    true_s = r.spheres[0].seconds;
    measured_s = r.spheres[1].seconds;
    spp = 0.5 * (r.spheres[0].noise.mean_samples + r.spheres[1].noise.mean_samples);
    p95 = std::max(r.spheres[0].noise.p95_rel_se, r.spheres[1].noise.p95_rel_se);
    de_mean = r.maps[0].stats.mean;
    de_p95 = r.maps[0].stats.p95;
    benchmark::DoNotOptimize(r.image.rgb.data());
    cpu_s = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  }
  state.counters["cpu_s"] = cpu_s;  // process CPU time: the figure to trust on a busy machine
  state.counters["measure_s"] = measure_s;
  state.counters["true_s"] = true_s;
  state.counters["measured_s"] = measured_s;
  state.counters["spp"] = spp;
  state.counters["p95_rel_se"] = p95;
  state.counters["de00_mean"] = de_mean;
  state.counters["de00_p95"] = de_p95;
  state.SetLabel("conductor α=0.05, sky, 2° key light, 2 threads");
}
BENCHMARK(BM_RenderPair)->Arg(512)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace
}  // namespace gonio::twin
