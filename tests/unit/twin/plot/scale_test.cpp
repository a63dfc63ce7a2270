// Axis scales and tick marks of the line plots on their own (gonio/twin/detail/plot/scale.hpp): nice
// steps, tick positions and labels on linear and logarithmic axes, data ranges and the
// mapping to device coordinates.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

// Private header of the plot family: the test exercises it directly.
#include "gonio/twin/detail/plot/scale.hpp"

namespace gonio::twin::plot {
namespace {

std::vector<std::string> labels(const std::vector<Tick>& ts) {
  std::vector<std::string> out;
  for (const auto& t : ts)
    if (t.major) out.push_back(t.label.sup.empty() ? t.label.base : t.label.base + "^" + t.label.sup);
  return out;
}

Scale linear(double lo, double hi) {
  Scale s;
  s.lo = lo;
  s.hi = hi;
  return s;
}

Scale logarithmic(double lo, double hi) {
  Scale s = linear(lo, hi);
  s.log = true;
  return s;
}

TEST(NiceStep, IsOneTwoOrFiveTimesAPowerOfTen) {
  EXPECT_DOUBLE_EQ(nice_step(1.0), 1.0);
  EXPECT_DOUBLE_EQ(nice_step(1.4), 1.0);
  EXPECT_DOUBLE_EQ(nice_step(1.6), 2.0);
  EXPECT_DOUBLE_EQ(nice_step(2.9), 2.0);
  EXPECT_DOUBLE_EQ(nice_step(3.1), 5.0);
  EXPECT_DOUBLE_EQ(nice_step(6.9), 5.0);
  EXPECT_DOUBLE_EQ(nice_step(7.1), 10.0);
  EXPECT_DOUBLE_EQ(nice_step(0.03), 0.05);
  EXPECT_DOUBLE_EQ(nice_step(180.0), 200.0);
  for (double x : {1e-7, 0.0123, 0.77, 3.3, 42.0, 9.9e5}) {
    const double s = nice_step(x);
    const double mantissa = s / std::pow(10.0, std::floor(std::log10(s) + 1e-12));
    EXPECT_TRUE(std::abs(mantissa - 1) < 1e-9 || std::abs(mantissa - 2) < 1e-9 ||
                std::abs(mantissa - 5) < 1e-9)
        << x << " -> " << s;
    EXPECT_GT(s, x / 3.1);
    EXPECT_LT(s, x * 2.1);
  }
}

TEST(FormatTick, UsesTheDecimalsOfTheStep) {
  EXPECT_EQ(format_tick(10, 5), "10");
  EXPECT_EQ(format_tick(0.25, 0.05), "0.25");
  EXPECT_EQ(format_tick(0.2, 0.1), "0.2");
  EXPECT_EQ(format_tick(1.5, 0.5), "1.5");
  EXPECT_EQ(format_tick(-30, 10), "-30");
  EXPECT_EQ(format_tick(0.001, 0.001), "0.001");
  EXPECT_EQ(format_tick(-1e-17, 0.1), "0.0");  // rounding noise at zero is not "-0.0"
  EXPECT_EQ(format_tick(-0.0, 1), "0");
}

TEST(LinearTicks, NiceStepsInsideTheRange) {
  // 700 units: ten labels wanted, a span of 180 gives a step of 20.
  const auto ts = ticks(linear(-90, 90), 700);
  EXPECT_EQ(labels(ts), (std::vector<std::string>{"-80", "-60", "-40", "-20", "0", "20", "40",
                                                  "60", "80"}));
  // 210 units: three labels wanted, step 50.
  EXPECT_EQ(labels(ticks(linear(-90, 90), 210)), (std::vector<std::string>{"-50", "0", "50"}));
  // Ends that fall on the step are kept despite rounding.
  EXPECT_EQ(labels(ticks(linear(0, 1), 350)),
            (std::vector<std::string>{"0.0", "0.2", "0.4", "0.6", "0.8", "1.0"}));
  for (const auto& t : ticks(linear(0.013, 0.087), 500)) {
    EXPECT_GE(t.v, 0.013);
    EXPECT_LE(t.v, 0.087);
    EXPECT_TRUE(t.major);
  }
}

TEST(LinearTicks, CountFollowsTheLength) {
  const auto few = ticks(linear(0, 100), 100).size();
  const auto many = ticks(linear(0, 100), 1000).size();
  EXPECT_GE(few, 2u);
  EXPECT_LE(few, 6u);
  EXPECT_GT(many, few);
  EXPECT_LE(many, 21u);
}

TEST(LogTicks, DecadesLabelledAsPowersOfTen) {
  const auto ts = ticks(logarithmic(1e-3, 10), 500);
  EXPECT_EQ(labels(ts), (std::vector<std::string>{"10^-3", "10^-2", "10^-1", "10^0", "10^1"}));
  // Unlabelled minor ticks at 2..9 within each decade: 4 decades × 8.
  int minor = 0;
  for (const auto& t : ts)
    if (!t.major) {
      ++minor;
      EXPECT_TRUE(t.label.base.empty());
    }
  EXPECT_EQ(minor, 32);
}

TEST(LogTicks, CrowdedDecadesAreLabelledEveryFew) {
  // Twelve decades on a short axis: every decade ticked, some unlabelled; no minor ticks
  // beyond six decades.
  const auto ts = ticks(logarithmic(1e-6, 1e6), 150);
  EXPECT_EQ(ts.size(), 13u);
  const auto l = labels(ts);
  int labelled = 0;
  for (const auto& s : l) labelled += s.empty() ? 0 : 1;
  EXPECT_GE(labelled, 2);
  EXPECT_LT(labelled, 13);
  EXPECT_EQ(l.front(), "10^-6");
}

TEST(LogTicks, NarrowRangeUsesPlainOneTwoFive) {
  const auto ts = ticks(logarithmic(0.15, 3), 400);
  EXPECT_EQ(labels(ts), (std::vector<std::string>{"0.2", "0.5", "1", "2"}));
  for (const auto& t : ts) EXPECT_TRUE(t.label.sup.empty());
}

TEST(Scale, MapsLinearlyOrByDecades) {
  Scale s = linear(0, 10);
  s.p0 = 100;
  s.p1 = 300;
  EXPECT_DOUBLE_EQ(s.map(0), 100);
  EXPECT_DOUBLE_EQ(s.map(2.5), 150);
  EXPECT_DOUBLE_EQ(s.map(10), 300);
  Scale l = logarithmic(1, 1000);
  l.p0 = 400;  // a y axis: device coordinates grow downwards
  l.p1 = 100;
  EXPECT_DOUBLE_EQ(l.map(10), 300);
  EXPECT_DOUBLE_EQ(l.map(100), 200);
  EXPECT_TRUE(l.valid(1e-9));
  EXPECT_FALSE(l.valid(0));
  EXPECT_FALSE(l.valid(-1));
  EXPECT_FALSE(s.valid(std::numeric_limits<double>::quiet_NaN()));
  EXPECT_TRUE(s.valid(-1));
}

TEST(AutoRange, PadsTheDataAndIncludesSigma) {
  std::vector<Series> series{Series("a", {0, 1, 2}, {1, 3, 2}, {0.5, 0.5, 0.5})};
  const auto [x0, x1] = auto_range(Axis("x"), series, false);
  EXPECT_DOUBLE_EQ(x0, -0.08);
  EXPECT_DOUBLE_EQ(x1, 2.08);
  const auto [y0, y1] = auto_range(Axis("y"), series, true);
  EXPECT_DOUBLE_EQ(y0, 0.5 - 0.04 * 3);
  EXPECT_DOUBLE_EQ(y1, 3.5 + 0.04 * 3);
}

TEST(AutoRange, LogAxisSkipsNonPositiveValues) {
  std::vector<Series> series{Series("a", {0, 1, 2, 3}, {-1, 0, 1e-2, 10})};
  const auto [lo, hi] = auto_range(Axis("y").logarithmic(), series, true);
  // Three decades padded by 4 % of their number on each side.
  EXPECT_NEAR(std::log10(lo), -2 - 0.12, 1e-12);
  EXPECT_NEAR(std::log10(hi), 1 + 0.12, 1e-12);
}

TEST(AutoRange, DegenerateData) {
  EXPECT_EQ(auto_range(Axis("y"), {}, true), (std::pair{0.0, 1.0}));
  EXPECT_EQ(auto_range(Axis("y").logarithmic(), {}, true), (std::pair{1.0, 10.0}));
  std::vector<Series> one{Series("a", {5}, {5})};
  EXPECT_EQ(auto_range(Axis("y"), one, true), (std::pair{4.0, 6.0}));
  // Points with a non-finite coordinate do not count.
  std::vector<Series> nan{Series("a", {1, std::nan("")}, {2, 100})};
  EXPECT_EQ(auto_range(Axis("x"), nan, false), (std::pair{0.0, 2.0}));
}

TEST(MakeScale, ExplicitBoundsWinAndOneSidedBoundsStayOrdered) {
  std::vector<Series> series{Series("a", {0, 10}, {1, 2})};
  const Scale s = make_scale(Axis("x").range(-5, 5), series, false);
  EXPECT_EQ(s.lo, -5);
  EXPECT_EQ(s.hi, 5);
  Axis above("x");
  above.min = 20;  // all the data below the given minimum
  const Scale a = make_scale(above, series, false);
  EXPECT_EQ(a.lo, 20);
  EXPECT_EQ(a.hi, 21);
  Axis below = Axis("y").logarithmic();
  below.max = 0.1;
  const Scale b = make_scale(below, series, true);
  EXPECT_TRUE(b.log);
  EXPECT_DOUBLE_EQ(b.hi, 0.1);
  EXPECT_DOUBLE_EQ(b.lo, 0.01);
}

TEST(AxisTitle, UnitInParentheses) {
  EXPECT_EQ(axis_title(Axis("receiving angle θr", "°")), "receiving angle θr (°)");
  EXPECT_EQ(axis_title(Axis("radiance factor β")), "radiance factor β");
}

}  // namespace
}  // namespace gonio::twin::plot
