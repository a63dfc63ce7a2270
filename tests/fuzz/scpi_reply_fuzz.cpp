// Fuzz target: every parser of SCPI reply bytes (numbers, lists, booleans, error queue
// entries, *IDN?) and the SCPI session's line framing. Malformed input must end in
// gonio::Error, never in a crash, a hang or an unbounded allocation.
#include <cstdint>
#include <string_view>

#include "gonio/drivers/scpi/scpi.hpp"
#include "gonio/proto/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view s(reinterpret_cast<const char*>(data), size);
  namespace scpi = gonio::drivers::scpi;
  const auto guarded = [](auto&& f) {
    try {
      f();
    } catch (const gonio::Error&) {
    }
  };
  guarded([&] { (void)scpi::parse_number(s); });
  guarded([&] { (void)scpi::parse_numbers(s, "fuzz", 1024); });
  guarded([&] { (void)scpi::parse_bool(s); });
  guarded([&] { (void)scpi::parse_error_entry(s); });
  guarded([&] { (void)scpi::parse_identity(s); });
  (void)scpi::trim(s);
  return 0;
}
