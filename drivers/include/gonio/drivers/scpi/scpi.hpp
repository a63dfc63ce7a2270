// SCPI — message exchange and reply parsing for SCPI instruments (IEEE 488.2-1992 and
// SCPI-1999), and the SCPI photometer driver with its presets.
//
// Replies are one line: program message terminator NL (IEEE 488.2 §8.5; a CR before it is
// tolerated), or the end of a USBTMC message (EOM). Numbers are NR1/NR2/NR3 (IEEE 488.2
// §8.7.2–8.7.4); SCPI-1999 Vol. 1 §7.2.1.5 reserves 9.9E37 for +infinity (−9.9E37 for
// −infinity) and 9.91E37 for "not a number". Error queue entries are <code>,"<text>"
// (SCPI-1999 Vol. 2 §21.8; code 0 is "No error", negative codes are standard, positive
// ones device specific).
//
// Presets of the photometer driver:
//   gonio  the spectral photometer command set of proto/scpi-gonio.md
//   pm100  Thorlabs PM100-class single-channel power meters: *IDN?, SENS:CORR:WAV <nm>,
//          MEAS:POW?; a spectrum is read one wavelength at a time (`repeats` readings per
//          wavelength give the mean and its standard error).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "gonio/proto/enum_text.hpp"
#include "gonio/drivers/photometer/photometer.hpp"
#include "gonio/drivers/transport/transport.hpp"

namespace gonio::drivers::scpi {

// ---- reply parsing (throws Error(protocol_error) naming `what` and quoting the reply) ----

// Strips trailing CR/LF and surrounding blanks.
std::string_view trim(std::string_view reply) noexcept;
// One decimal number (NR1/NR2/NR3); 9.9E37 → ±inf, 9.91E37 → NaN.
double parse_number(std::string_view reply, std::string_view what = "number");
// Comma-separated numbers; at most `max_count`.
std::vector<double> parse_numbers(std::string_view reply, std::string_view what = "numbers",
                                  std::size_t max_count = 65536);
// "0", "1", "ON", "OFF" (IEEE 488.2 §8.7.2 boolean as NR1).
bool parse_bool(std::string_view reply, std::string_view what = "boolean");

struct ErrorEntry {
  int code = 0;
  std::string message;
  friend bool operator==(const ErrorEntry&, const ErrorEntry&) = default;
};
// <code>,"<text>" — the text may contain doubled quotes.
ErrorEntry parse_error_entry(std::string_view reply);
// *IDN? reply: four comma-separated fields (IEEE 488.2 §10.14).
Identity parse_identity(std::string_view reply);

// ---- message exchange ------------------------------------------------------------------

struct SessionOptions {
  std::string terminator = "\n";        // appended to every command
  std::size_t max_reply = 1u << 20;     // longer replies are a protocol error
  bool has_error_queue = true;          // SYST:ERR? is understood
};

// Resynchronisation: after a timeout (the reply may still come) or a reply that broke the
// protocol (it may have been an earlier query's), the session is out of step, and the next
// exchange first brings it back: the link is cleared (pending input dropped; USBTMC: device
// clear, INITIATE_CLEAR) unless markers of an earlier attempt are still unanswered, then
// `*OPC?` (IEEE 488.2 §10.18) is sent and every line up to its "1" is dropped. A device answers in order, so whatever a late reply was, it came
// before that "1"; markers that went unanswered are counted, so that a late "1" of an
// earlier attempt is not taken for the current one. A session that cannot be resynchronised
// before the call's deadline throws Error(disconnected): the link is unusable and the
// device must be reopened.
class Session {
 public:
  explicit Session(TransportPtr transport, SessionOptions options = {});

  Transport& transport() noexcept { return *t_; }
  // Sends a command (no reply expected).
  void command(std::string_view cmd, Deadline deadline);
  // Sends a query and returns its reply line (trimmed). On timeout the session is
  // resynchronised and, if the device has an error queue, the device's own error is
  // reported as device_alarm (a SCPI device sends no reply to a query it rejected).
  std::string query(std::string_view cmd, Deadline deadline);
  // Reads SYST:ERR? until "0,..." (at most 32 entries).
  std::vector<ErrorEntry> drain_errors(Deadline deadline);
  // Throws Error(device_alarm) with the first queued error, after `cmd` was sent.
  void check_errors(std::string_view cmd, Deadline deadline);
  void cancel() noexcept { t_->cancel(); }

  // The caller found a reply that breaks the protocol: resynchronise before the next exchange.
  void mark_out_of_step() noexcept { out_of_step_ = true; }
  // Resynchronises now (see above); a no-op when in step.
  void resync(Deadline deadline);

 private:
  std::string read_line(Deadline deadline);
  void send(std::string_view cmd, Deadline deadline);
  std::vector<ErrorEntry> drain_errors_in_step(Deadline deadline);

  TransportPtr t_;
  SessionOptions opt_;
  std::string buf_;  // received bytes not yet returned
  bool out_of_step_ = false;
  int markers_ = 0;  // *OPC? markers sent and not yet answered
};

// ---- photometer driver -----------------------------------------------------------------

enum class Preset { gonio, pm100 };
inline constexpr EnumNames<Preset, 2> kPresetNames{{
    {Preset::gonio, "gonio"},
    {Preset::pm100, "pm100"},
}};
constexpr const auto& enum_names(Preset) { return kPresetNames; }  // proto/enum_text.hpp

struct PhotometerConfig {
  Preset preset = Preset::gonio;
  std::optional<WavelengthGrid> wavelengths;  // pm100: required, the channels to read
  int repeats = 3;                             // pm100: readings per wavelength, 1..1000
  int averages = 0;                            // pm100: SENS:AVER:COUN (0: leave as set)
  bool check_errors = true;                    // gonio: SYST:ERR? after every setting
  std::chrono::milliseconds open_timeout{5000};

  // Reads preset, wavelengths, repeats, averages, check_errors, open_timeout_ms.
  static PhotometerConfig read(json_util::ObjectReader& r);
};

// Takes over a connected transport. Nothing is sent until the first call.
std::unique_ptr<Photometer> make_photometer(TransportPtr transport, PhotometerConfig config);

// Registry entry points: opens the transport of `transport_type` ("serial", "tcp",
// "usbtmc") from the same JSON object that holds the photometer keys; unknown keys rejected.
std::unique_ptr<Photometer> make_photometer(std::string_view transport_type,
                                            const nlohmann::json& config);
// Reads the same config as make_photometer, with the same errors, and returns the device
// it names without opening it.
DeviceRef check_photometer(std::string_view transport_type, const nlohmann::json& config);

}  // namespace gonio::drivers::scpi
