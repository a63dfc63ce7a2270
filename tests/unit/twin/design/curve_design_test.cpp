// CurveDesign against curves whose truth is known exactly (analytic, not the twin's): the
// loop stops with the estimate within the tolerance, and the delivered curve is then within
// it everywhere (beyond the readings' k·u), for peaks of many widths and noise draws.
#include <cmath>
#include <functional>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/design.hpp"

namespace gonio::twin {
namespace {

std::vector<Geometry> candidates(double lo, double hi) {
  std::vector<Geometry> out;
  for (double r = lo; r <= hi + 1e-9; r += 1) out.push_back(Geometry::in_plane(45, r));
  return out;
}

struct Outcome {
  std::size_t points = 0;
  double estimated = 0, actual = 0;
  bool reached = false;
};

// Runs the loop as goniod does (next() with nothing pending, then the reading), on f.
Outcome run(const std::function<double(double)>& f, double tolerance, double noise_rel, std::uint64_t seed) {
  const auto cand = candidates(-20, 80);
  CurveDesignOptions o;
  o.tolerance = tolerance;
  CurveDesign d(cand, o);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  const auto read = [&](std::size_t c) {
    const double t = f(cand[c].theta_r), u = std::hypot(noise_rel * t, 1e-6);
    d.add(c, MeasuredPoint{cand[c], {t + u * normal(rng)}, {u}});
  };
  for (const auto c : d.seeds()) read(c);
  d.update();
  Geometry arms = cand.back();
  while (auto c = d.next({}, arms)) {
    read(*c);
    arms = cand[*c];
    d.update();
  }
  Outcome out;
  out.points = d.measured();
  out.reached = d.target_reached();
  out.estimated = d.status().estimated_error.value_or(1e300);
  double peak = 0;
  for (const auto& g : cand) peak = std::max(peak, f(g.theta_r));
  for (std::size_t c = 0; c < cand.size(); ++c) {
    const auto v = d.interpolate(c);
    const double t = f(cand[c].theta_r), u = std::hypot(noise_rel * t, 1e-6);
    // Relative as the tolerance is: to max(β, floor × peak).
    out.actual = std::max(out.actual, std::max(0.0, std::abs(v.at(0) - t) - o.coverage_k * u) / std::max(t, o.floor * peak));
  }
  return out;
}

// A lobe about the specular direction (45°) on a diffuse floor, of width w degrees.
std::function<double(double)> lobe(double w, double peak, double floor) {
  return [=](double r) { return floor + peak * std::exp(-0.5 * std::pow((r - 45) / w, 2)); };
}

TEST(CurveDesign, TheEstimateCoversTheActualErrorOverManyCurvesAndNoiseDraws) {
  int runs = 0, covered = 0;
  for (const double w : {1.0, 1.5, 2.5, 4.0, 6.0, 9.0, 14.0, 20.0})
    for (const double tol : {0.005, 0.01, 0.02, 0.05})
      for (std::uint64_t seed = 1; seed <= 3; ++seed) {
        const auto r = run(lobe(w, seed == 2 ? 300 : 20, seed == 3 ? 0.5 : 0.05), tol, 0.001, seed);
        ASSERT_TRUE(r.reached) << "w " << w << " tol " << tol;
        EXPECT_LE(r.estimated, tol);
        ++runs;
        covered += r.actual <= tol ? 1 : 0;
        // Never far off, even when not covered.
        EXPECT_LE(r.actual, 1.5 * tol) << "w " << w << " tol " << tol << " seed " << seed;
      }
  EXPECT_GE(covered, runs * 95 / 100) << covered << " of " << runs;
}

TEST(CurveDesign, FewPointsWhereTheCurveIsSmoothMoreWhereItBends) {
  const auto flat = run([](double r) { return 0.5 + 0.001 * r; }, 0.01, 0.001, 1);
  const auto sharp = run(lobe(2, 50, 0.01), 0.01, 0.001, 1);
  EXPECT_LE(flat.points, 15u);  // the seeds alone: 10° apart, both ends, specular, retro
  EXPECT_GT(sharp.points, flat.points + 5);
  EXPECT_LT(sharp.points, 101u / 2);
}

TEST(CurveDesign, NoiseBelowItsUncertaintyIsNotChased) {
  // A constant curve read with 1 % noise: the gaps are noise, within k·u.
  const auto r = run([](double) { return 0.3; }, 0.005, 0.01, 3);
  EXPECT_TRUE(r.reached);
  EXPECT_LE(r.points, 20u);
}

TEST(CurveDesign, SeedsSpanEachCurveAndIncludeTheSpecularAndRetroDirections) {
  auto cand = candidates(-60, 80);
  for (double r = -60; r <= 80; r += 1) cand.push_back(Geometry::in_plane(20, r));
  CurveDesign d(cand, CurveDesignOptions{});
  const auto seeds = d.seeds();
  std::set<std::pair<double, double>> at;
  for (const auto c : seeds) at.insert({cand[c].theta_i, cand[c].theta_r});
  for (const double ti : {45.0, 20.0}) {
    EXPECT_TRUE(at.count({ti, -60}) && at.count({ti, 80}));
    EXPECT_TRUE(at.count({ti, ti})) << "specular at " << ti;
    EXPECT_TRUE(at.count({ti, -ti})) << "retro at " << ti;
  }
  // No gap wider than the seed spacing on either curve.
  for (const double ti : {45.0, 20.0}) {
    double last = -1e9;
    for (const auto& [i, r] : at) {
      if (i != ti) continue;
      if (last > -1e9) {
        EXPECT_LE(r - last, 10 + 1e-9);
      }
      last = r;
    }
  }
  // Sweeps: consecutive seeds of one curve move one way.
  for (std::size_t k = 2; k < seeds.size(); ++k) {
    if (cand[seeds[k]].theta_i != cand[seeds[k - 2]].theta_i || cand[seeds[k - 1]].theta_i != cand[seeds[k]].theta_i)
      continue;
    EXPECT_GT((cand[seeds[k]].theta_r - cand[seeds[k - 1]].theta_r) * (cand[seeds[k - 1]].theta_r - cand[seeds[k - 2]].theta_r), 0);
  }
}

TEST(CurveDesign, RefusesACandidateTwiceAndBadOptionsNameTheirField) {
  CurveDesign d(candidates(0, 10), CurveDesignOptions{});
  d.add(0, MeasuredPoint{{}, {1}, {0.01}});
  EXPECT_THROW(d.add(0, MeasuredPoint{{}, {1}, {0.01}}), Error);
  CurveDesignOptions o;
  o.tolerance = 0;
  try {
    CurveDesign bad(candidates(0, 10), o);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "tolerance");
  }
}

}  // namespace
}  // namespace gonio::twin
