// The inverse twin's speed targets: a 1–3 parameter fit (and a calibration) to ~100 points ×
// 31 channels, and a painted panel's 38 parameters to 300 points × 35 channels, each in
// ≤ 10 s on two cores. Data come from the independent quadrature of the
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

#include "gonio/test/ideal_instrument.hpp"
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

// A painted panel: 300 in-plane geometries (θi = 15…75°, θr = −80…80°) × 35 channels
// (380–720 nm), the layered model with three nonlinear parameters (α, ior, haze) and a
// per-channel albedo (38 parameters), through the twin. Target ≤ 10 s on two cores.
void BM_FitPaint(benchmark::State& state) {
  static const MeasuredData data = [] {
    const auto grid = WavelengthGrid::parse("380:720:10");
    std::vector<Geometry> geometries;
    for (double ti : {15.0, 30.0, 45.0, 60.0, 75.0})
      for (int k = 0; k < 60; ++k) geometries.push_back(Geometry::in_plane(ti, -80 + 160.0 * k / 59));
    test::IdealInstrument ideal;
    ideal.nodes = 6;
    const auto truth = make_bsdf(
        "plastic:albedo=380:0.05,450:0.08,550:0.4,650:0.6,720:0.65,alpha=0.08,ior=1.5,haze=0.3,"
        "haze_alpha=0.3",
        grid);
    return ideal.measure(*truth, geometries, 0.01, 1e-3, 5);
  }();
  FitOptions o;
  o.threads = 2;
  FitResult r;
  for (auto _ : state)
    r = fit_material(data, "plastic:albedo=?*,alpha=?,ior=?,haze=?,haze_alpha=0.3",
                     InstrumentProfile::preset("gcms4"), o);
  const auto n = r.parameters.size();
  report(state, r, {});
  state.counters["alpha"] = r.parameters[n - 3].value;
  state.counters["z_alpha"] = (r.parameters[n - 3].value - 0.08) / r.parameters[n - 3].u;
  state.counters["ior"] = r.parameters[n - 2].value;
  state.counters["z_ior"] = (r.parameters[n - 2].value - 1.5) / r.parameters[n - 2].u;
  state.counters["haze"] = r.parameters[n - 1].value;
  state.counters["z_haze"] = (r.parameters[n - 1].value - 0.3) / r.parameters[n - 1].u;
  state.counters["parameters"] = static_cast<double>(n);
}
BENCHMARK(BM_FitPaint)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace
