// gonio-twin convert: write a tabulated BSDF — loaded from a file, or virtually measured
// from a model — as IS-SA .bsdf or SSDD (by the output's extension).
#include <iostream>

#include <fmt/format.h>

#include "cli/common.hpp"
#include "cli/output.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf_io.hpp"
#include "gonio/twin/color.hpp"
#include "gonio/twin/virtual_measurement.hpp"

namespace gonio::twin::cli {
namespace {

// A spectral table written as monochrome IS-SA carries its luminance factor (CIE 15:2004 §7:
// ȳ(λ)·D65(λ) weights), rather than a plain mean that counts 400 nm like 555 nm.
IssaWriteOptions luminance_weighted(const TabulatedParts& parts) {
  IssaWriteOptions o;
  const BsdfTable* t = parts.brdf ? &*parts.brdf : parts.btdf ? &*parts.btdf : nullptr;
  if (t != nullptr) o.weights = luminance_weights(t->wavelengths());
  if (!o.weights.empty())
    o.comment = "Monochrome = luminance factor: channels weighted by CIE 1964 10 deg y-bar x D65";
  return o;
}

}  // namespace

void add_convert(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "convert", "write a loaded or virtually measured tabulated BSDF as .bsdf or .ssdd");
  auto model = std::make_shared<ModelOptions>();
  auto input = std::make_shared<std::string>();
  auto output = std::make_shared<std::string>();
  auto theta_step = std::make_shared<double>(5.0);
  auto phi_step = std::make_shared<double>(15.0);
  model->add_to(*sub, false);
  sub->add_option("--input", *input, "tabulated file to convert (.bsdf, .ssdd, .binary)");
  sub->add_option("--output", *output, "output file: .bsdf (IS-SA) or .ssdd")->required();
  sub->add_option("--theta-step", *theta_step, "virtual measurement: θi and θo step, degrees")
      ->capture_default_str();
  sub->add_option("--phi-step", *phi_step, "virtual measurement: φo step, degrees")
      ->capture_default_str();
  sub->callback([=] {
    exit_code() = guarded([&] {
      TabulatedParts parts;
      if (!input->empty()) {
        if (!model->bsdf.empty())
          throw Error::invalid("input", "give either --input FILE or --bsdf SPEC, not both");
        parts = read_bsdf_file(*input);
      } else {
        if (model->bsdf.empty())
          throw Error::invalid("bsdf", "give --input FILE or --bsdf SPEC (virtually measured)");
        const auto twin = model->make_twin();
        const auto table = measure_tabulated(
            twin, measurement_grid(*theta_step, *phi_step), model->estimator_options(),
            model->threads);
        parts = table->parts();
        parts.name = table->spec();
      }
      try {
        write_bsdf_file(*output, parts, luminance_weighted(parts));
      } catch (const Error& e) {
        if (e.code() == Errc::not_found) throw Error(Errc::io_error, e.what(), "output");
        throw;
      }
      std::cout << fmt::format("wrote {}\n", *output);
      return kExitOk;
    });
  });
}

}  // namespace gonio::twin::cli
