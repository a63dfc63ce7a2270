// Photometer — the detector side of the instrument (docs/architecture.md §4).
//
// A photometer reads a spectrum of detector signal on its wavelength grid: the sample
// channel, the reference channel (the white standard of a double-beam instrument) or the
// dark signal (shutter closed / source blocked). Readings are raw detector signal with the
// standard uncertainty (k = 1) of every wavelength channel; the caller forms the radiance
// factor β = (S − D) / (R − D) × β_reference from sample, dark and reference readings.
//
// A single-beam meter (capabilities().dual_beam == false) reads both channels on the same
// detector: the caller puts the reference plate in the beam before measuring `reference`.
//
// Every call blocks for at most its timeout and fails with gonio::Error:
//   timeout        the device did not answer in time
//   disconnected   the link dropped (port closed, cable pulled, peer closed the socket)
//   protocol_error the device answered with bytes that break its protocol
//   device_alarm   the device reports an error (its code and text are in the message)
//   saturated      a channel of the reading reached the detector's full scale
//   busy           the device or port is in use by someone else
//   unsupported    the device cannot do what was asked (see capabilities())
// A driver is used from one thread at a time; cancel() may be called from any thread.
#pragma once

#include <chrono>
#include <string>
#include <string_view>

#include "gonio/proto/enum_text.hpp"
#include "gonio/proto/spectrum.hpp"

namespace gonio::drivers {

using std::chrono::milliseconds;

enum class Channel { sample, reference, dark };

inline constexpr EnumNames<Channel, 3> kChannelNames{{
    {Channel::sample, "sample"},
    {Channel::reference, "reference"},
    {Channel::dark, "dark"},
}};
constexpr const auto& enum_names(Channel) { return kChannelNames; }  // proto/enum_text.hpp

// *IDN? fields (IEEE 488.2 §10.14): manufacturer, model, serial number, firmware.
struct Identity {
  std::string manufacturer;
  std::string model;
  std::string serial;
  std::string firmware;

  std::string to_string() const;  // "manufacturer model (serial), firmware"
  friend bool operator==(const Identity&, const Identity&) = default;
};

struct Reading {
  Channel channel = Channel::sample;
  Spectrum spectrum;            // raw detector signal and its standard uncertainty per channel
  std::string unit;             // "counts" for spectrometers, "W" for power meters
  double integration_ms = 0;    // integration time the reading used (0: unknown)
  bool saturated = false;       // some channel reached full scale
};

struct PhotometerCapabilities {
  bool dual_beam = false;              // separate sample and reference channels
  bool dark_shutter = false;           // dark() closes a shutter (else: the caller blocks the beam)
  bool settable_integration = false;   // set_integration_ms() is supported
  bool uncertainty_from_device = false;  // per-channel uncertainty comes from the device
};

enum class SaturationPolicy {
  throw_error,  // measure() throws Error(saturated) naming the channel
  flag,         // measure() returns the reading with saturated = true
};

class Photometer {
 public:
  virtual ~Photometer() = default;
  Photometer() = default;
  Photometer(const Photometer&) = delete;
  Photometer& operator=(const Photometer&) = delete;

  virtual PhotometerCapabilities capabilities() const = 0;

  virtual Identity identify(milliseconds timeout) = 0;
  // The channels every reading uses.
  virtual WavelengthGrid wavelengths(milliseconds timeout) = 0;

  virtual double integration_ms(milliseconds timeout) = 0;
  // Throws Error(out_of_range) for a time the device does not allow, Error(unsupported)
  // when capabilities().settable_integration is false.
  virtual void set_integration_ms(double ms, milliseconds timeout) = 0;

  // Reads one channel. A dark reading never throws for saturation.
  virtual Reading measure(Channel channel, milliseconds timeout,
                          SaturationPolicy policy = SaturationPolicy::throw_error) = 0;
  Reading dark(milliseconds timeout) { return measure(Channel::dark, timeout); }

  // Makes a call in progress on another thread fail soon with Error(timeout) ("cancelled").
  // Later calls work normally. Default: nothing to cancel (calls are short).
  virtual void cancel() noexcept {}
};

// Throws Error(saturated) naming the channel if `r` is saturated and policy says so.
void check_saturation(const Reading& r, SaturationPolicy policy);

}  // namespace gonio::drivers
