// Fuzz target: the SSDD reader (ASCII and binary data from outside), with the checks every
// tabulated reader gets (gonio/test/tabulated_fuzz.hpp).
#include <cstdint>

#include "gonio/test/tabulated_fuzz.hpp"
#include "gonio/twin/bsdf_io.hpp"

namespace {

gonio::twin::TabulatedParts read(std::istream& in, std::string_view source) {
  return gonio::twin::read_ssdd(in, source);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return gonio::test::fuzz_tabulated_reader(data, size, &read, "fuzz.ssdd");
}
