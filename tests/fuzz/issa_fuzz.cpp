// Fuzz target: the Zemax/Radiant IS-SA .bsdf reader (text from outside). Besides the
// shared checks (gonio/test/tabulated_fuzz.hpp), IS-SA written back from the table it
// read reads back identical.
#include <cstdint>

#include "gonio/test/tabulated_fuzz.hpp"
#include "gonio/twin/bsdf_io.hpp"

namespace {

void write_back(std::ostream& out, const gonio::twin::TabulatedParts& parts) {
  const gonio::twin::BsdfTable& t = parts.brdf ? *parts.brdf : *parts.btdf;
  gonio::twin::write_issa(out, t, !parts.brdf);
}

gonio::twin::TabulatedParts read(std::istream& in, std::string_view source) {
  return gonio::twin::read_issa(in, source);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return gonio::test::fuzz_tabulated_reader(data, size, &read, "fuzz.bsdf", &write_back);
}
