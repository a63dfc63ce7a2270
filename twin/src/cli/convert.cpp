// gonio-twin convert: write a tabulated BSDF — loaded from a file, or tabulated from a model
// (its true BSDF, or its virtual measurement through the instrument) — as IS-SA .bsdf or
// SSDD (by the output's extension).
//
// A model is tabulated in the specular parametrization (IS-SA's native one) on a grid that
// follows the lobe (lobe_grid): radial and azimuthal nodes refined until interpolation stays
// within --grid-error of the model, then checked for energy — the table's directional
// reflectance, integrated as readers interpolate it, within 2 % of the model's at every θi.
// A spherical grid of fixed steps cannot do that: a lobe a few degrees wide sampled at its
// peak is spread over a whole cell (3.6 instead of 0.84 at θi = 85° for α = 0.1).
#include <chrono>
#include <iostream>

#include <fmt/format.h>

#include "cli/common.hpp"
#include "cli/output.hpp"
#include "cli/progress.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf_io.hpp"
#include "gonio/twin/color.hpp"
#include "gonio/twin/virtual_measurement.hpp"

namespace gonio::twin::cli {
namespace {

const BsdfTable* main_table(const TabulatedParts& parts) {
  return parts.brdf ? &*parts.brdf : parts.btdf ? &*parts.btdf : nullptr;
}

// IS-SA spectral content. A spectral table is written as CIE XYZ tristimulus blocks
// (SpectralContent XYZ of the IS-SA format; D65, CIE 1964 10° observer, scaled so that Y is
// the luminance factor: a white table of f = 1/π has X, Y, Z = Xn/Yn, 1, Zn/Yn); with
// `monochrome` — or for a grey table — as one Monochrome block holding the luminance factor
// (CIE 15:2004 §7: ȳ(λ)·D65(λ) weights), rather than a plain mean that counts 400 nm like
// 555 nm.
IssaWriteOptions issa_options(const TabulatedParts& parts, bool monochrome) {
  IssaWriteOptions o;
  const BsdfTable* t = main_table(parts);
  if (t == nullptr || t->wavelengths().size() < 2) return o;
  if (!monochrome) o.xyz_weights = xyz_weights(t->wavelengths());
  if (o.xyz_weights) {
    o.comment = "XYZ: CIE 1964 10 deg observer, D65; Y = luminance factor (1 for a white "
                "diffuser of f = 1/pi)";
    return o;
  }
  o.weights = luminance_weights(t->wavelengths());
  if (!o.weights.empty())
    o.comment = "Monochrome = luminance factor: channels weighted by CIE 1964 10 deg y-bar x D65";
  return o;
}

double luminance(const std::vector<double>& albedo, const std::vector<double>& weights) {
  if (weights.size() != albedo.size()) {
    double s = 0;
    for (double x : albedo) s += x;
    return albedo.empty() ? 0 : s / static_cast<double>(albedo.size());
  }
  double s = 0;
  for (std::size_t c = 0; c < albedo.size(); ++c) s += weights[c] * albedo[c];
  return s;
}

}  // namespace

void add_convert(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "convert", "write a loaded or tabulated (true or virtually measured) BSDF as .bsdf or .ssdd");
  auto model = std::make_shared<ModelOptions>();
  auto input = std::make_shared<std::string>();
  auto output = std::make_shared<std::string>();
  auto theta_step = std::make_shared<double>(5.0);
  auto phi_step = std::make_shared<double>(15.0);
  auto tolerance = std::make_shared<double>(0.02);
  auto virtual_measurement = std::make_shared<bool>(false);
  auto monochrome = std::make_shared<bool>(false);
  auto binary = std::make_shared<bool>(false);
  model->add_to(*sub, false);
  sub->add_option("--input", *input, "tabulated file to convert (.bsdf, .ssdd, .binary)");
  sub->add_option("--output", *output, "output file: .bsdf (IS-SA) or .ssdd")->required();
  sub->add_option("--theta-step", *theta_step, "model: θi step, degrees (0 to 85)")
      ->capture_default_str();
  sub->add_option("--phi-step", *phi_step,
                  "model: the coarsest azimuth step about the specular direction, degrees")
      ->capture_default_str();
  auto* grid_error = sub->add_option("--grid-error", *tolerance,
                                     "model: largest relative interpolation error of the lobe-following grid")
                         ->capture_default_str();
  // The old name: --tolerance is a sample's acceptance limit everywhere else (gonioctl).
  auto* old_name = sub->add_option("--tolerance", *tolerance)->group("");
  sub->add_flag("--virtual", *virtual_measurement,
                "model: fill the grid with the instrument's virtual measurement instead of the "
                "true BSDF");
  sub->add_flag("--monochrome", *monochrome,
                ".bsdf: one Monochrome block (luminance factor) instead of XYZ");
  sub->add_flag("--binary", *binary, ".ssdd: binary data (float32) instead of text");
  sub->callback([=] {
    exit_code() = guarded([&] {
      if (old_name->count() > 0 && grid_error->count() > 0)
        throw Error::invalid("tolerance", "give --grid-error alone (--tolerance is its old name)");
      if (old_name->count() > 0) std::cerr << "gonio-twin convert: --tolerance is now --grid-error\n";
      TabulatedParts parts;
      SsddWriteOptions ssdd;
      if (*binary) ssdd.data = SsddData::binary;
      ssdd.name_entry = false;  // a comment: no reader uses NAME
      const auto t0 = std::chrono::steady_clock::now();
      Ticker ticker("convert");
      if (!input->empty()) {
        ticker.step("reading " + *input);
        if (!model->bsdf.empty())
          throw Error::invalid("input", "give either --input FILE or --bsdf SPEC, not both");
        parts = read_bsdf_file(*input);
      } else {
        if (model->bsdf.empty())
          throw Error::invalid("bsdf", "give --input FILE or --bsdf SPEC (tabulated)");
        if (!(*theta_step >= 0.5 && *theta_step <= 45))
          throw Error::out_of_range("theta-step", *theta_step, 0.5, 45, "°");
        if (!(*tolerance >= 0.002 && *tolerance <= 0.5))
          throw Error::out_of_range("grid-error", *tolerance, 0.002, 0.5);
        const auto twin = model->make_twin();
        const Bsdf& bsdf = twin.sample();
        LobeGridOptions lo;
        for (int k = 0;; ++k) {
          const double t = std::min(85.0, k * *theta_step);
          lo.theta_i.push_back(std::round(t * 1e6) / 1e6);
          if (t >= 85) break;
        }
        lo.tolerance = *tolerance;
        lo.azimuth_step = *phi_step;
        LobeGridReport rep;
        const SpecularGrid grid = lobe_grid(bsdf, lo, &rep);
        std::cerr << fmt::format(
            "lobe-following grid: {} θi × {} radial × {} azimuth nodes (grid error {:g})\n",
            grid.theta_i.size(), grid.radial.size(), grid.azimuth.size(), rep.tolerance);
        if (*virtual_measurement) {
          std::cerr << fmt::format("measuring {} geometries ...\n",
                                   specular_geometries(grid).geometries.size());
          ticker.step(fmt::format("measuring {} geometries", specular_geometries(grid).geometries.size()));
          parts.brdf = measure_specular(twin, grid, model->estimator_options(), model->threads);
          parts.name = "virtually measured " + bsdf.spec();
          ssdd.device = twin.profile().name;
        } else {
          parts = tabulate_parts(bsdf, AngularGrid{grid.theta_i, {}, {0}, {0}, true});
          parts.brdf = tabulate_specular(bsdf, grid);
          parts.name = bsdf.spec();
        }
        ssdd.source = SsddSource::generated;
        // Energy: the table's reflectance as a reader integrates it, against the model's.
        const auto w = luminance_weights(bsdf.wavelengths().values());
        double worst = 0, worst_ti = 0;
        for (const double ti : grid.theta_i) {
          const double t = luminance(table_albedo(*parts.brdf, ti), w);
          const double m = luminance(model_albedo(bsdf, ti, grid.radial, grid.azimuth), w);
          const double e = (t - m) / std::max(m, 1e-3);
          if (std::abs(e) > std::abs(worst)) {
            worst = e;
            worst_ti = ti;
          }
        }
        std::cerr << fmt::format("reflectance of the table vs the model: largest difference "
                                 "{:+.2f} % at θi = {:g}°\n", 100 * worst, worst_ti);
      }
      std::vector<std::string> warnings;
      ticker.step("writing " + *output);
      try {
        warnings = write_bsdf_file(*output, parts, issa_options(parts, *monochrome), ssdd);
      } catch (const Error& e) {
        if (e.code() == Errc::not_found) throw Error(Errc::io_error, e.what(), "output");
        throw;
      }
      for (const auto& w : warnings) std::cerr << "warning: " << w << '\n';
      const double secs =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::cout << fmt::format("wrote {} ({}, {:.1f} s)\n", *output, file_size_text(*output), secs);
      return kExitOk;
    });
  });
}

}  // namespace gonio::twin::cli
