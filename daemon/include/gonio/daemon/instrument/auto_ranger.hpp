// AutoRanger — the auto-ranging loop of one point's readings (docs/architecture.md §6,
// step 3) on the runner thread: from the nominal integration time, read the dark, the
// reference white (when due, or when the one in hand is at another setting) and the
// sample, and read them again at the setting the rule of autorange.hpp gives until it keeps
// them. It also remembers, across runs, the nominal setting and the setting last given to
// the photometer (so that it is not set again for every point).
#pragma once

#include <chrono>
#include <functional>
#include <optional>
#include <string>

#include "gonio/daemon/instrument/autorange.hpp"
#include "gonio/drivers/photometer/photometer.hpp"

namespace gonio::daemon {

// The reference white and its dark as last read, kept from point to point of a run.
struct ReferenceReadings {
  std::optional<drivers::Reading> white, dark;
};

// What one point read: the dark and sample at one setting, whether the reference white was
// read (again) for it, and that setting (0: the photometer does not range).
struct PointReadings {
  drivers::Reading dark, sample;
  bool read_reference = false;
  double integration_ms = 0;
};

class AutoRanger {
 public:
  struct Settings {
    bool enabled = true;
    std::optional<double> integration_ms;  // configured nominal setting; else the photometer's own
    RangeLimits limits;
    std::chrono::milliseconds timeout{10000};
  };
  // `beat` before every photometer call (the watchdog's heartbeat).
  AutoRanger(Settings s, std::function<void()> beat);

  // The photometer was opened (again): the setting it holds is unknown.
  void reopened() { set_.reset(); }
  // The setting every point starts at; 0 when the photometer does not range (autorange off,
  // or its integration time is not settable).
  double nominal_ms(drivers::Photometer& p);
  // One point's readings from `nominal_ms`; `reference_due`: the plan reads the reference
  // white at this point. `ref` is updated when the reference is read. `what` names the point
  // in the debug log. Throws the photometer's Error; Error(saturated) when the shortest
  // setting still saturates.
  PointReadings read(drivers::Photometer& p, double nominal_ms, bool reference_due, ReferenceReadings& ref,
                     const std::string& what);

 private:
  void set(drivers::Photometer& p, double ms);

  Settings s_;
  std::function<void()> beat_;
  std::optional<double> nominal_;  // once known
  std::optional<double> set_;      // the setting last given to the photometer
};

}  // namespace gonio::daemon
