// Auto-ranging of the photometer's integration time (docs/architecture.md §6, step 3).
//
// A point is read at the scan's nominal integration time first. A saturated sample or
// reference reading shortens it by kRangeStep and the dark, the reference and the sample are
// read again at the new setting (β = β_ref (S − D) / (R − D_R) needs all four at one
// setting, the signal being proportional to the integration time); only when the shortest
// allowed setting still saturates is the point a device fault. An under-exposed sample —
// its best channel's net signal S − D under `underexposed_snr` times its own standard
// uncertainty, i.e. near the dark level — lengthens it by the same step, up to the longest
// allowed setting and never to a setting that saturated at this point. Starting every
// point from the nominal setting keeps a point's exposure a function of that point's light
// alone, whatever the points before it and across a resume.
//
// Pure decisions, apart from the runner so that they can be tested without an instrument.
#pragma once

#include <optional>

#include "gonio/drivers/photometer/photometer.hpp"

namespace gonio::daemon {

// Each ranging step changes the integration time by this factor (about two stops: few
// re-reads, and the detector keeps at least a quarter of its range at the chosen setting).
inline constexpr double kRangeStep = 4;

struct RangeLimits {
  double min_ms = 1;
  double max_ms = 2000;
  double underexposed_snr = 10;
};

// max over channels of (S − D) / sqrt(u_S² + u_D²); 0 for empty readings.
double best_channel_snr(const drivers::Reading& sample, const drivers::Reading& dark);

// The setting to read again at after a reading at `t_ms`, or nullopt to keep this reading.
// `saturated`: the sample or the reference reading saturated; `snr`: best_channel_snr of the
// sample; `ceiling_ms`: the shortest setting that saturated at this point (or nullopt).
// Throws nothing: a saturated reading at the shortest setting returns nullopt, and the
// caller makes it a fault.
std::optional<double> next_integration_ms(double t_ms, bool saturated, double snr,
                                          std::optional<double> ceiling_ms, const RangeLimits& lim);

}  // namespace gonio::daemon
