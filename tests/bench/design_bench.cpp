// Adaptive scans (twin/design.md): what the twin's next choice costs, which goniod computes
// while the arms serve the current point (target ≤ 1 s on 2 cores, so that it never delays
// them), and what the loop saves against the uniform grid.
//
//   build/ci/bin/bench --benchmark_filter=Adaptive
#include <benchmark/benchmark.h>

#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/design.hpp"
#include "gonio/twin/twin.hpp"

namespace gonio::twin {
namespace {

// One step of the parameters loop with `measured` points in hand: a warm refit and the
// next choice over 116 candidates (in=45, out=−35…80 every 1°: the side of the collision
// zone the arms can reach, 10° clearance), 31 channels, 2 threads —
// a glossy conductor with hidden roughness α = 0.02.
void BM_AdaptiveChoice(benchmark::State& state) {
  const auto measured = static_cast<std::size_t>(state.range(0));
  const auto grid = WavelengthGrid::visible();
  std::vector<Geometry> cand;
  for (double r = -35; r <= 80 + 1e-9; r += 1) cand.push_back(Geometry::in_plane(45, r));
  const Twin truth(InstrumentProfile{}, make_bsdf("conductor:alpha=0.02,eta=0.2,k=3.9", grid), grid);
  EstimatorOptions est;
  est.rel_se = 2e-3;
  est.max_samples = 1ull << 22;  // the settings twin/design.md was measured with
  est.replicates = 32;
  const auto pred = truth.predict_many(cand, est, 2);
  ParameterDesignOptions o;
  o.threads = 2;
  o.fit.threads = 2;
  o.fit.samples = 1u << 12;  // goniod's refit budget (daemon/src/instrument/adaptive_loop.cpp)
  o.fit.replicates = 8;
  o.fit.max_iterations = 30;
  ParameterDesign d("conductor:alpha=?,eta=0.2,k=3.9", cand, grid, InstrumentProfile{}, o);
  const auto read = [&](std::size_t c) {
    MeasuredPoint p{cand[c], pred[c].beta, {}};
    for (double b : p.beta) p.u.push_back(std::hypot(0.002 * b, 0.002));
    d.add(c, p);
  };
  // The seeds, then the loop's own choices up to `measured` points.
  for (const auto c : d.seeds()) read(c);
  d.update();
  Geometry arms = cand[d.seeds().back()];
  while (d.measured() < measured) {
    const auto c = d.next({}, arms);
    if (!c) break;
    read(*c);
    arms = cand[*c];
    d.update();
  }
  std::size_t pending = 0;
  for (auto _ : state) {
    d.update();
    const auto c = d.next({}, arms);
    benchmark::DoNotOptimize(c);
    pending = c.value_or(0);
  }
  state.counters["points"] = static_cast<double>(d.measured());
  state.counters["next_theta_r"] = cand[pending].theta_r;
}
BENCHMARK(BM_AdaptiveChoice)->Arg(8)->Arg(30)->Unit(benchmark::kMillisecond)->Iterations(3)->UseRealTime();

// The whole study of `gonio-twin design`: the uniform grid's fit and the adaptive loop on
// the same virtual sample. Counters: points and modelled instrument time, adaptive over
// uniform, and the two relative u(α).
void BM_AdaptiveStudy(benchmark::State& state) {
  std::vector<Geometry> cand;
  for (double r = -35; r <= 80 + 1e-9; r += 1) cand.push_back(Geometry::in_plane(45, r));
  DesignStudyOptions so;
  so.truth = "conductor:alpha=0.02,eta=0.2,k=3.9";
  so.noise_rel = so.noise_abs = 0.002;
  so.max_points = 60;
  so.measurement.rel_se = 1e-3;  // the settings twin/design.md was measured with
  so.measurement.max_samples = 1ull << 22;
  so.measurement.replicates = 32;
  so.parameters.threads = so.parameters.fit.threads = 2;
  so.parameters.target_rel_u = 4.8e-5;  // the uniform grid's, measured
  DesignStudy s;
  for (auto _ : state) s = study_design("conductor:alpha=?,eta=0.2,k=3.9", cand, WavelengthGrid::visible(), InstrumentProfile{}, so);
  const auto rel = [](const DesignRun& r) { return r.status.parameters.at(0).u / r.status.parameters.at(0).value; };
  state.counters["points_ratio"] = static_cast<double>(s.adaptive.chosen.size()) / static_cast<double>(s.uniform.chosen.size());
  state.counters["time_ratio"] = s.adaptive.seconds / s.uniform.seconds;
  state.counters["rel_u_uniform"] = rel(s.uniform);
  state.counters["rel_u_adaptive"] = rel(s.adaptive);
  state.counters["choice_s_max"] = s.adaptive.choice_seconds_max;
}
BENCHMARK(BM_AdaptiveStudy)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace
}  // namespace gonio::twin
