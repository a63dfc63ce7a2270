// Instrument::Run — the state of the scan being measured, shared by the files that implement
// Instrument (instrument.cpp, run.cpp, commands.cpp). Owned by the
// runner thread; the pointer to it is guarded by Instrument::mu_.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <string>

#include "gonio/daemon/instrument/adaptive_loop.hpp"
#include "gonio/daemon/instrument/divergence.hpp"
#include "gonio/daemon/instrument/instrument.hpp"
#include "gonio/daemon/instrument/point_reduction.hpp"
#include "gonio/daemon/instrument/verdict.hpp"
#include "gonio/drivers/photometer/photometer.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {

// A failure of a device's link rather than of one request: the device is closed and opened
// again (Instrument::drop_device).
inline bool is_link_error(Errc c) { return c == Errc::disconnected || c == Errc::io_error; }

// What step 3 read for one point, and the seconds the devices took (for the overhead figure).
struct Instrument::PointReadings {
  drivers::Reading dark, sample;
  bool read_reference = false;  // the reference white was read (again) for this point
  double device_s = 0;
};

struct Instrument::Run {
  Scan scan;
  double tolerance = 0;
  std::optional<std::int64_t> sample_id;
  std::shared_ptr<TwinService::Batch> batch;
  std::shared_ptr<const ScanTwin> scan_twin;  // kept for an adaptive scan's per-point batches
  // An adaptive scan: its loop, the candidate of the next point, and whether the loop has
  // started choosing the one after it (a point measured again after a fault does not).
  std::unique_ptr<AdaptiveLoop> adaptive;
  std::optional<std::size_t> candidate;
  bool choosing = false;
  std::shared_ptr<const twin::Colorimeter> colorimeter;
  std::string prediction_note;  // why there are no predictions
  std::string twin_version;     // of the profile the run started with
  double reference_beta = 1.0;  // that profile's β of the reference white
  std::size_t next = 0;         // next point index to measure
  std::size_t since_start = 0;  // points measured in this run
  // The reference white and its dark, last read; at reference->integration_ms.
  std::optional<drivers::Reading> reference, reference_dark;
  // Where every point's auto-ranging starts, found at the run's first reading; 0: the
  // photometer does not range (autorange off, or its integration time is not settable).
  std::optional<double> nominal_ms;
  ReferenceDriftMonitor drift{DivergenceSettings{}.reference_drift};
  ScanEvidence evidence{0, 2};     // every point of the scan, stored ones included
  std::string spec;               // the sample's catalogued BSDF
  std::string verdict_stored;     // decision and cause of the verdict last stored
  double busy_seconds = 0;  // wall time of the points of this run (for the ETA)
  bool sustained_raised = false;
  std::size_t since_judged = 0;  // points since the verdict was last judged
};

}  // namespace gonio::daemon
