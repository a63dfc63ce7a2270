// The inverse twin's speed target: a 1–3 parameter fit (and a calibration) to ~100 points ×
// 31 channels in ≤ 10 s on two cores. Data come from the independent quadrature of the
// ideal instrument (tests/unit/twin/fit/ideal_instrument.hpp), not from the twin.
//
//   build/<preset>/bin/bench --benchmark_filter=Fit
//
// Counters: the fitted values and their deviations from the truth in units of u, χ²/dof,
// Jacobian iterations and whole-data-set evaluations.
#include <map>
#include <string>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include "../unit/twin/fit/ideal_instrument.hpp"
#include "gonio/twin/fit.hpp"

namespace {

using namespace gonio;
using namespace gonio::twin;

const MeasuredData& data_for(const std::string& spec, double receive_offset, double gain) {
  static std::map<std::string, MeasuredData> cache;
  const auto key = fmt::format("{}|{}|{}", spec, receive_offset, gain);
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  const auto grid = WavelengthGrid::parse("400:700:10");
  test::IdealInstrument ideal;
  ideal.profile.arms.receive_offset_deg = receive_offset;
  ideal.gain = gain;
  ideal.nodes = 8;
  return cache.emplace(key, ideal.measure(*make_bsdf(spec, grid), test::specular_scan(), 0.01,
                                          1e-4, 42)).first->second;
}

void report(benchmark::State& state, const FitResult& r, const std::vector<double>& truth) {
  for (std::size_t j = 0; j < r.parameters.size() && j < truth.size(); ++j) {
    const auto& p = r.parameters[j];
    state.counters["p" + std::to_string(j)] = p.value;
    state.counters["z" + std::to_string(j)] = (p.value - truth[j]) / p.u;
  }
  state.counters["chi2_dof"] = r.chi2_per_dof;
  state.counters["iterations"] = r.iterations;
  state.counters["evaluations"] = r.evaluations;
  state.counters["points"] = static_cast<double>(r.points);
  state.counters["channels"] = static_cast<double>(r.residuals / r.points);
}

// α of a GGX conductor (1 parameter), and α with η and k (3 parameters).
void BM_FitConductor(benchmark::State& state) {
  const auto& data = data_for("conductor:alpha=0.04,eta=0.2,k=3.9", 0, 1);
  const bool three = state.range(0) == 3;
  const std::string model = three ? "conductor:alpha=?0.1,eta=?0.5[0.05,2],k=?3[1,6]"
                                  : "conductor:alpha=?0.1,eta=0.2,k=3.9";
  FitOptions o;
  o.threads = 2;
  FitResult r;
  for (auto _ : state) r = fit_material(data, model, InstrumentProfile::preset("gcms4"), o);
  report(state, r, {0.04, 0.2, 3.9});
}
BENCHMARK(BM_FitConductor)->Arg(1)->Arg(3)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

// Receive-arm offset −0.2° and gain 1.02 on a known conductor.
void BM_Calibrate(benchmark::State& state) {
  const auto& data = data_for("conductor:alpha=0.04,eta=0.2,k=3.9", -0.2, 1.02);
  FitOptions o;
  o.threads = 2;
  FitResult r;
  for (auto _ : state)
    r = calibrate(data, "conductor:alpha=0.04,eta=0.2,k=3.9", {"receive_offset_deg", "gain"},
                  InstrumentProfile::preset("gcms4"), o);
  report(state, r, {-0.2, 1.02});
}
BENCHMARK(BM_Calibrate)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace
