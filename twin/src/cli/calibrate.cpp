// gonio-twin calibrate: instrument parameters fitted on a sample of known BSDF
// (twin/fitting.md).
#include <fstream>
#include <iostream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/common.hpp"
#include "cli/fit_output.hpp"
#include "cli/output.hpp"
#include "cli/progress.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"

namespace gonio::twin::cli {

void add_calibrate(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "calibrate", "fit instrument parameters (arm offsets, tilt, apertures, gain) on a known sample");
  auto o = std::make_shared<FitCliOptions>();
  auto sample = std::make_shared<std::string>();
  auto fit = std::make_shared<std::string>();
  auto profile_out = std::make_shared<std::string>();
  sub->add_option("--sample", *sample, "the known sample's BSDF spec")->required();
  sub->add_option("--fit", *fit,
                  "comma-separated parameters: incidence_offset_deg, receive_offset_deg, "
                  "sample_tilt_deg, source_aperture_scale, receiver_aperture_scale, gain")
      ->required();
  o->add_to(*sub);
  sub->add_option("--profile-out", *profile_out,
                  "write the corrected instrument profile (JSON, usable with --profile)");
  sub->callback([o, sample, fit, profile_out] {
    exit_code() = guarded([&] {
      std::vector<std::string> names;
      for (const auto part : text::split(*fit, ','))
        if (!text::trim(part).empty()) names.emplace_back(text::trim(part));
      const auto data = load_measured(o->measured, o->table_u);
      const auto profile = o->load_profile();
      const auto options = o->options();
      const auto r = [&] {
        Ticker ticker("calibrate");  // erased before the result is printed
        ticker.step(fmt::format("fitting {} to {} points", *fit, data.points.size()));
        return calibrate(data, *sample, names, profile, options);
      }();
      if (o->json)
        std::cout << r.to_json().dump(2) << '\n';
      else
        write_fit_table(std::cout, r,
                        fmt::format("calibration of the {} profile on {} ({})", profile.name,
                                    data.source, *sample));
      if (!profile_out->empty()) {
        std::ofstream out(*profile_out);
        out << nlohmann::json(*r.profile).dump(2) << '\n';
        if (!out)
          throw Error(Errc::io_error, fmt::format("cannot write '{}'", *profile_out), "profile-out");
      }
      if (!o->plot.empty()) {
        auto high = options;
        high.samples = std::max<std::uint64_t>(options.samples, 1u << 16);
        Ticker ticker("calibrate");
        ticker.step("correcting the measured points");
        plot_fit(o->plot, correct(data, r.spec, *r.profile, high),
                 fmt::format("calibration on {}", r.spec), r);
      }
      // What was written and how big; beside --json's document, not in it.
      auto& said = o->json ? std::cerr : std::cout;
      for (const auto* path : {profile_out.get(), &o->plot})
        if (!path->empty()) said << fmt::format("wrote {} ({})\n", *path, file_size_text(*path));
      return kExitOk;
    });
  });
}

}  // namespace gonio::twin::cli
