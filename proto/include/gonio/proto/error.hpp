// gonio::Error — the one typed error that crosses module boundaries.
//
// Every failure that a user can see carries an Errc with a stable string id and a
// stable numeric code (documented in proto/errors.md; JSON-RPC server codes map onto
// them), a human message, and — for validation failures — the name of the offending
// field. Ids and numbers never change meaning once released; new ones are appended.
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>

namespace gonio {

enum class Errc : int {
  invalid_argument = 1,  // malformed value: wrong type, unknown key, bad syntax
  out_of_range = 2,      // well-formed value outside its allowed range
  parse_error = 3,       // a file or reply could not be parsed
  not_found = 4,         // named thing (file, sample, scan, preset) does not exist
  unsupported = 5,       // valid request the component cannot do
  io_error = 6,          // operating-system I/O failure
  timeout = 10,          // device or peer did not answer in time
  disconnected = 11,     // link to a device dropped
  device_alarm = 12,     // device reports an alarm (its code is in the message)
  protocol_error = 13,   // device answered with bytes that break its protocol
  limit_violation = 14,  // motion would leave soft limits or enter the collision zone
  busy = 15,             // device or resource is busy
  saturated = 16,        // detector saturated
  invalid_state = 20,    // operation not allowed in the current state
  unauthorized = 21,     // no or bad credentials
  forbidden = 22,        // credentials lack the role
  plan_rejected = 23,    // a scan plan failed validation
  storage_unavailable = 24,  // the store cannot write (disk full, read-only, I/O error): reads go on
  internal = 99,         // a bug: should never reach a user
};

// "a" + "b" -> "a.b"; "a" + "[2]" -> "a[2]"; either may be empty.
std::string join_field(std::string_view prefix, std::string_view field);

// Stable identifier, e.g. "out_of_range".
std::string_view errc_id(Errc code) noexcept;
// Inverse of errc_id; Errc::internal for unknown ids.
Errc errc_from_id(std::string_view id) noexcept;

class Error : public std::runtime_error {
 public:
  Error(Errc code, std::string message, std::string field = {});

  Errc code() const noexcept { return code_; }
  std::string_view id() const noexcept { return errc_id(code_); }
  // The offending field ("geometry[3].theta_r", "wavelengths"), empty when none.
  const std::string& field() const noexcept { return field_; }

  // "<field> = <value> is outside [lo, hi]<unit>"
  static Error out_of_range(std::string field, double value, double lo, double hi,
                            std::string_view unit = {});
  // "<field>: <message>" (invalid_argument)
  static Error invalid(std::string field, std::string message);
  // "<field>: <what> does not exist" (not_found), e.g. not_found("scan", "scan 7").
  static Error not_found(std::string field, std::string_view what);
  // "<field>: <what> already exists" (invalid_state), e.g. exists("name", "a sample named 'tile'").
  static Error exists(std::string field, std::string_view what);
  // "<field>: <why>" (invalid_state): the request is valid but not now, e.g.
  // wrong_state("scan", "scan 7 is completed; only paused scans can be resumed").
  static Error wrong_state(std::string field, std::string_view why);
  // "<action> needs the <needed> role; '<who>' has <has>" (forbidden).
  static Error forbidden(std::string_view action, std::string_view needed, std::string_view who,
                         std::string_view has);

 private:
  Errc code_;
  std::string field_;
};

}  // namespace gonio
