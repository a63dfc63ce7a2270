// Axis scales and tick marks for the line plots (figure.cpp), kept apart from any drawing so
// that they can be tested on their own: the data range of an axis (padded, positive values
// only on a logarithmic axis), the mapping from data to device coordinates, and tick
// positions with their labels. Linear ticks follow Heckbert's "nice numbers" (Graphics Gems,
// 1990): steps of 1, 2 or 5 times a power of ten. Logarithmic axes tick at decades, labelled
// 10ⁿ (base and raised exponent), with 2 and 5 as plain numbers when they span little.
#pragma once

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "gonio/twin/plot.hpp"

namespace gonio::twin::plot {

// A tick label: base text with an optional raised exponent ("10" + "-3").
struct Label {
  std::string base, sup;
};

struct Scale {
  double lo = 0, hi = 1;  // data range
  bool log = false;
  double p0 = 0, p1 = 1;  // device coordinates of lo and hi
  double t(double v) const { return log ? std::log10(v) : v; }
  double map(double v) const { return p0 + (t(v) - t(lo)) / (t(hi) - t(lo)) * (p1 - p0); }
  bool valid(double v) const { return std::isfinite(v) && (!log || v > 0); }
};

struct Tick {
  double v;
  Label label;
  bool major;  // labelled (or a decade); minor ticks are drawn shorter
};

// Heckbert's nice number: 1, 2, 5 or 10 times a power of ten, close to x (x > 0).
double nice_step(double x);

// v with as many decimals as `step` needs ("0.25" for step 0.05, "10" for step 5); never "-0".
std::string format_tick(double v, double step);

// The ticks of `s` on an axis `length_px` device units long: about one label per 70 units
// on a linear axis; on a logarithmic one, every decade (every k-th labelled when they crowd)
// with unlabelled minor ticks at 2..9 up to six decades, or 1, 2, 5 labelled in plain
// numbers when the axis spans under 1.5 decades.
std::vector<Tick> ticks(const Scale& s, double length_px);

// Data range of an axis over the series (x or y values; y widened by ±σ): finite values
// (positive ones on a log axis), padded by 4 % (of the decades on a log axis); a single
// value gets a range around it, no data gives [0, 1] or [1, 10].
std::pair<double, double> auto_range(const Axis& axis, const std::vector<Series>& series,
                                     bool is_y);

// The scale of an axis: its explicit bounds where given, else auto_range; a single bound
// with the data beyond it gets one unit (a decade on a log axis) on its other side. The
// device coordinates are left for the layout to set.
Scale make_scale(const Axis& axis, const std::vector<Series>& series, bool is_y);

// "label (unit)", or the label alone without a unit.
std::string axis_title(const Axis& a);

}  // namespace gonio::twin::plot
