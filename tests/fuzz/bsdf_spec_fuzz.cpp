// Fuzz target for the BSDF spec parser (string and JSON forms): any input either builds
// a model or throws gonio::Error; nothing else may escape, and an accepted model must
// evaluate, sample and round-trip its canonical spec. Inputs naming files ('@') are only
// parsed, not built, so the target never touches the file system.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "gonio/twin/detail/bsdf/spec.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf.hpp"

namespace {

using gonio::twin::BsdfPtr;
using gonio::twin::Vec3;

void check(bool ok) {
  if (!ok) std::abort();
}

void exercise(const BsdfPtr& b, const gonio::WavelengthGrid& grid) {
  std::vector<double> f(b->channels());
  const Vec3 dirs[] = {{0, 0, 1}, {0.6, 0, 0.8}, {-0.8, 0.1, 0.59160797830996}, {0.3, 0.4, -0.866025403784}};
  for (const auto& wo : dirs) {
    for (const auto& wi : dirs) {
      b->eval(wi, wo, f);
      for (const double v : f) check(std::isfinite(v) && v >= 0);
      const double p = b->pdf(wo, wi);
      check(std::isfinite(p) && p >= 0);
    }
    const auto s = b->sample_wi(wo, 0.37, {0.21, 0.83});
    if (s) check(std::isfinite(s->pdf) && s->pdf > 0);
  }
  check(gonio::twin::make_bsdf(b->spec(), grid)->spec() == b->spec());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const auto grid = gonio::WavelengthGrid::parse("400:700:50");
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const bool files = text.find('@') != std::string_view::npos;
  try {
    if (files) {
      (void)gonio::twin::bsdf::parse_spec_string(text);
    } else {
      exercise(gonio::twin::make_bsdf(text, grid), grid);
    }
  } catch (const gonio::Error&) {
  }
  // The same bytes as JSON, when they are JSON.
  const auto j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return 0;
  try {
    if (files) {
      (void)gonio::twin::bsdf::parse_spec_json(j);
    } else {
      exercise(gonio::twin::make_bsdf(j, grid), grid);
    }
  } catch (const gonio::Error&) {
  }
  return 0;
}
