// The fuzz harness shared by the tabulated-format readers (tests/fuzz/issa_fuzz.cpp,
// ssdd_fuzz.cpp, merl_fuzz.cpp): each target is one call to fuzz_tabulated_reader with its
// reader, so that every format gets the same checks.
#pragma once

#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <string_view>

#include "gonio/twin/tabulated.hpp"

namespace gonio::test {

// Reads a format from a stream naming its source in messages (read_issa, read_ssdd, ...).
using TabulatedReader = twin::TabulatedParts (*)(std::istream& in, std::string_view source);
// Writes parts back in the reader's own format, if it can hold them.
using TabulatedWriter = void (*)(std::ostream& out, const twin::TabulatedParts& parts);

// Feeds `data` to `read` (as a file named `source`). A gonio::Error is a clean reject.
// Whatever is accepted must evaluate to finite, non-negative values (and delta-lobe
// weights), survive an SSDD write → read round trip unchanged and, given `write_back`, a
// round trip through its own format too. A violation traps: a finding for the fuzzer, a
// crash for the seed replay. Returns 0, as LLVMFuzzerTestOneInput does.
int fuzz_tabulated_reader(const std::uint8_t* data, std::size_t size, TabulatedReader read,
                          std::string_view source, TabulatedWriter write_back = nullptr);

}  // namespace gonio::test
