// The tabulated-format fuzz harness (tabulated_fuzz.hpp).
#include "gonio/test/tabulated_fuzz.hpp"

#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf_io.hpp"

namespace gonio::test {
namespace {

using namespace gonio::twin;

void check(bool ok) {
  if (!ok) __builtin_trap();
}

void exercise(const TabulatedParts& parts) {
  static const WavelengthGrid grid = WavelengthGrid::parse("450,550,650");
  const TabulatedBsdf b(grid, parts);
  std::vector<double> f(3);
  const Vec3 dirs[] = {{0, 0, 1}, {0.6, 0, 0.8}, {-0.48, 0.6, 0.64}, {0.8, 0, -0.6}, {0, 1, 0}};
  for (const auto& wi : dirs)
    for (const auto& wo : dirs) {
      b.eval(wi, wo, f);
      for (const double x : f) check(std::isfinite(x) && x >= 0);
    }
  std::vector<DeltaLobe> lobes;
  b.delta_lobes(dirs[1], lobes);
  for (const auto& l : lobes)
    for (const double w : l.weight) check(std::isfinite(w) && w >= 0);
  // SSDD can hold every part exactly (ASCII).
  std::ostringstream out;
  write_ssdd(out, parts);
  std::istringstream in(out.str());
  check(read_ssdd(in, "round-trip") == parts);
}

}  // namespace

int fuzz_tabulated_reader(const std::uint8_t* data, std::size_t size, TabulatedReader read,
                          std::string_view source, TabulatedWriter write_back) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  TabulatedParts parts;
  try {
    parts = read(in, source);
  } catch (const gonio::Error&) {
    return 0;
  }
  exercise(parts);
  if (write_back != nullptr) {
    std::ostringstream out;
    write_back(out, parts);
    std::istringstream again(out.str());
    check(read(again, "fuzz-round-trip") == parts);
  }
  return 0;
}

}  // namespace gonio::test
