// Point reduction — from the raw photometer readings of one point to the radiance factor β
// and its standard uncertainty, and the reference white drift over a run.
//
// Per photometer channel c, with S the sample reading, D the dark read with it, R the
// reference white reading and D_R the dark read with that reference:
//     β_c = β_ref (S_c − D_c) / (R_c − D_R,c)
// β_ref is the calibrated radiance factor of the reference white (InstrumentProfile). The
// standard uncertainty is the first-order propagation of the four readings' uncertainties,
// taken as independent (when the reference is read at the same point, D_R is D itself; that
// correlation is not modelled):
//     u_c² = (β_ref / n_R)² (u_S² + u_D²) + (β_c / n_R)² (u_R² + u_DR²)
// with n_R = R_c − D_R,c.
// β and u are then resampled linearly from the photometer's grid onto the plan's grid.
// A reference signal not above dark makes the point meaningless (lamp off, shutter stuck):
// that is a device fault, not a number.
//
// Kept apart from the runner so that the arithmetic can be tested without an instrument.
#pragma once

#include <optional>
#include <vector>

#include "gonio/proto/spectrum.hpp"

namespace gonio::daemon {

// The four readings of a point, raw detector signal with per-channel uncertainty, all on the
// photometer's grid (that of `sample`).
struct PointSignals {
  const Spectrum& sample;
  const Spectrum& dark;            // read just before the sample
  const Spectrum& reference;       // the reference white
  const Spectrum& reference_dark;  // the dark read with the reference
};

struct ReducedPoint {
  Spectrum beta;                       // β and u on the target grid
  std::vector<double> net_reference;   // R − D_R on the photometer's grid (for drift)
};

// Throws Error(protocol_error) when the readings have different channel counts and
// Error(device_alarm, field "reference") naming the wavelength when R − D_R is not above 0.
ReducedPoint reduce_point(const PointSignals& signals, double beta_reference,
                          const WavelengthGrid& target);

// `values` on grid `from` linearly interpolated onto `to` (constant beyond the ends);
// unchanged when the grids are equal.
std::vector<double> resample(const WavelengthGrid& from, const std::vector<double>& values,
                             const WavelengthGrid& to);

// Drift of the dark-corrected reference white signal against the first one seen in a run
// (reference_drift() in divergence.hpp: the relative change of the channel mean).
class ReferenceDriftMonitor {
 public:
  // `limit`: the relative drift allowed, e.g. 0.05 for 5 %.
  explicit ReferenceDriftMonitor(double limit) : limit_(limit) {}

  double limit() const noexcept { return limit_; }
  bool has_baseline() const noexcept { return !baseline_.empty(); }
  // The first reading becomes the baseline (nullopt). Later ones return their drift when it
  // is above the limit, else nullopt.
  std::optional<double> observe(const std::vector<double>& net_reference);

 private:
  double limit_;
  std::vector<double> baseline_;
};

}  // namespace gonio::daemon
