// Point reduction tests: β and u by hand, the propagation against finite differences and a
// Monte Carlo draw, a reference not above dark, resampling onto the plan's grid, drift.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "gonio/daemon/instrument/point_reduction.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {
namespace {

const WavelengthGrid kTwo = WavelengthGrid::parse("500,600");

ReducedPoint reduce(const Spectrum& s, const Spectrum& d, const Spectrum& r, const Spectrum& dr,
                    double beta_ref, const WavelengthGrid& target) {
  return reduce_point(PointSignals{.sample = s, .dark = d, .reference = r, .reference_dark = dr},
                      beta_ref, target);
}

TEST(PointReduction, BetaAndUncertaintyByHand) {
  const Spectrum S(kTwo, {1100, 350}, {10, 5});
  const Spectrum D(kTwo, {100, 50}, {2, 1});
  const Spectrum R(kTwo, {2100, 1050}, {20, 10});
  const Spectrum DR(kTwo, {100, 50}, {2, 1});
  const auto p = reduce(S, D, R, DR, 0.98, kTwo);
  ASSERT_EQ(p.beta.size(), 2u);
  EXPECT_EQ(p.beta.wavelengths, kTwo);
  // 0.98 · 1000 / 2000 and 0.98 · 300 / 1000.
  EXPECT_NEAR(p.beta.values[0], 0.49, 1e-15);
  EXPECT_NEAR(p.beta.values[1], 0.294, 1e-15);
  // u² = (0.98/2000)² (10² + 2²) + (0.49/2000)² (20² + 2²)
  EXPECT_NEAR(p.beta.std_uncertainty[0], 0.0070157323210054134, 1e-15);
  // u² = (0.98/1000)² (5² + 1²) + (0.294/1000)² (10² + 1²)
  EXPECT_NEAR(p.beta.std_uncertainty[1], 0.0058052076620909955, 1e-15);
  EXPECT_EQ(p.net_reference, (std::vector<double>{2000, 1000}));
}

TEST(PointReduction, ExactReadingsHaveNoUncertaintyAndSampleBelowDarkGoesNegative) {
  const auto g = WavelengthGrid::parse("550");
  const auto p = reduce(Spectrum(g, {40}), Spectrum(g, {50}), Spectrum(g, {550}),
                        Spectrum(g, {50}), 1.0, g);
  EXPECT_NEAR(p.beta.values[0], -0.02, 1e-15);  // noise below dark is kept, not clipped
  EXPECT_EQ(p.beta.std_uncertainty[0], 0.0);
}

// β as a function of the four signals of one channel.
double beta_of(double s, double d, double r, double dr, double beta_ref) {
  const auto g = WavelengthGrid::parse("550");
  return reduce(Spectrum(g, {s}), Spectrum(g, {d}), Spectrum(g, {r}), Spectrum(g, {dr}), beta_ref, g)
      .beta.values[0];
}

TEST(PointReduction, UncertaintyMatchesFiniteDifferences) {
  const double beta_ref = 0.975;
  const double x[4] = {830, 120, 1900, 95};  // S, D, R, D_R
  const double ux[4] = {7, 3, 11, 2.5};
  const auto g = WavelengthGrid::parse("550");
  const auto p = reduce(Spectrum(g, {x[0]}, {ux[0]}), Spectrum(g, {x[1]}, {ux[1]}),
                        Spectrum(g, {x[2]}, {ux[2]}), Spectrum(g, {x[3]}, {ux[3]}), beta_ref, g);
  double var = 0;
  for (int k = 0; k < 4; ++k) {
    double lo[4] = {x[0], x[1], x[2], x[3]}, hi[4] = {x[0], x[1], x[2], x[3]};
    const double h = 1e-3;
    lo[k] -= h;
    hi[k] += h;
    const double dbeta = (beta_of(hi[0], hi[1], hi[2], hi[3], beta_ref) -
                          beta_of(lo[0], lo[1], lo[2], lo[3], beta_ref)) /
                         (2 * h);
    var += dbeta * dbeta * ux[k] * ux[k];
  }
  EXPECT_NEAR(p.beta.std_uncertainty[0], std::sqrt(var), 1e-9 * std::sqrt(var));
}

TEST(PointReduction, UncertaintyMatchesAMonteCarloDraw) {
  const double beta_ref = 0.99;
  const double x[4] = {1500, 200, 3000, 180};
  const double ux[4] = {12, 4, 20, 4};  // small against the signals: first order holds
  const auto g = WavelengthGrid::parse("550");
  const auto p = reduce(Spectrum(g, {x[0]}, {ux[0]}), Spectrum(g, {x[1]}, {ux[1]}),
                        Spectrum(g, {x[2]}, {ux[2]}), Spectrum(g, {x[3]}, {ux[3]}), beta_ref, g);
  std::mt19937_64 rng(20240611);
  std::normal_distribution<double> n01;
  const int n = 200000;
  double sum = 0, sum2 = 0;
  for (int i = 0; i < n; ++i) {
    double v[4];
    for (int k = 0; k < 4; ++k) v[k] = x[k] + ux[k] * n01(rng);
    const double b = beta_ref * (v[0] - v[1]) / (v[2] - v[3]);
    sum += b;
    sum2 += b * b;
  }
  const double mean = sum / n;
  const double sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(p.beta.values[0], mean, 3 * sd / std::sqrt(n) + 1e-4);
  // The spread of a 200 000 draw is known to ~0.2 %; the linearisation is good to ~0.1 %.
  EXPECT_NEAR(p.beta.std_uncertainty[0], sd, 0.02 * sd);
}

TEST(PointReduction, ReferenceNotAboveDarkIsADeviceAlarmNamingTheWavelength) {
  const Spectrum S(kTwo, {500, 500}), D(kTwo, {100, 100});
  for (const double r600 : {100.0, 90.0}) {  // equal to dark, then below it
    try {
      reduce(S, D, Spectrum(kTwo, {900, r600}), Spectrum(kTwo, {100, 100}), 1.0, kTwo);
      FAIL() << "a reference at " << r600 << " over a dark of 100 was accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), Errc::device_alarm);
      EXPECT_EQ(e.field(), "reference");
      EXPECT_NE(std::string(e.what()).find("600 nm"), std::string::npos) << e.what();
    }
  }
}

TEST(PointReduction, ReadingsOfDifferentLengthsAreAProtocolError) {
  const auto three = WavelengthGrid::parse("500,550,600");
  const Spectrum two(kTwo, {500, 500});
  try {
    reduce(two, two, Spectrum(three, {900, 900, 900}), two, 1.0, kTwo);
    FAIL() << "mismatched readings were accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::protocol_error);
  }
}

TEST(PointReduction, ResultsAreResampledOntoThePlanGrid) {
  const auto photometer = WavelengthGrid::parse("400,500,600");
  const auto plan = WavelengthGrid::parse("450,550,650");
  // β = 0.2, 0.4, 0.8 with exact darks and reference 1000; u = 0.01·(1, 2, 4).
  const Spectrum S(photometer, {200, 400, 800}, {10, 20, 40});
  const Spectrum zero(photometer, {0, 0, 0});
  const Spectrum R(photometer, {1000, 1000, 1000});
  const auto p = reduce(S, zero, R, zero, 1.0, plan);
  EXPECT_EQ(p.beta.wavelengths, plan);
  EXPECT_NEAR(p.beta.values[0], 0.3, 1e-12);   // halfway between 400 and 500 nm
  EXPECT_NEAR(p.beta.values[1], 0.6, 1e-12);
  EXPECT_NEAR(p.beta.values[2], 0.8, 1e-12);   // beyond the end: constant
  EXPECT_NEAR(p.beta.std_uncertainty[0], 0.015, 1e-12);
  EXPECT_NEAR(p.beta.std_uncertainty[1], 0.03, 1e-12);
  EXPECT_NEAR(p.beta.std_uncertainty[2], 0.04, 1e-12);
  EXPECT_EQ(p.net_reference.size(), 3u);  // drift is on the photometer's own channels
  EXPECT_EQ(resample(photometer, {1, 2, 3}, photometer), (std::vector<double>{1, 2, 3}));
}

TEST(PointReduction, DriftIsAgainstTheFirstReferenceAndOnlyAboveTheLimit) {
  ReferenceDriftMonitor m(0.05);
  EXPECT_FALSE(m.has_baseline());
  EXPECT_FALSE(m.observe({1000, 2000}).has_value());  // the baseline
  EXPECT_TRUE(m.has_baseline());
  EXPECT_FALSE(m.observe({970, 1940}).has_value());   // −3 %
  const auto d = m.observe({1060, 2120});             // +6 %
  ASSERT_TRUE(d.has_value());
  EXPECT_NEAR(*d, 0.06, 1e-12);
  EXPECT_NEAR(m.observe({930, 1860}).value_or(0), 0.07, 1e-12);  // −7 %, still the first baseline
  EXPECT_FALSE(m.observe({1000, 2000}).has_value());
  EXPECT_EQ(m.limit(), 0.05);
}

TEST(PointReduction, DriftWithoutAPositiveBaselineIsNeverReported) {
  ReferenceDriftMonitor m(0.05);
  m.observe({0, 0});
  EXPECT_FALSE(m.observe({1000, 1000}).has_value());
  EXPECT_FALSE(m.observe({1, 2, 3}).has_value());  // a different channel count
}

}  // namespace
}  // namespace gonio::daemon
