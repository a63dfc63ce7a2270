// gonioctl twin: β(λ) predicted by goniod's twin, without the hardware.
#include <algorithm>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "ctl/ctl_internal.hpp"
#include "gonio/daemon/ctl/ctl.hpp"

namespace gonio::daemon::ctl {

using nlohmann::json;

namespace {

struct TwinArgs {
  std::string bsdf, sample, wavelengths = "400:700:10";
  std::vector<std::string> geometries, grids;
};

}  // namespace

void add_twin_commands(CLI::App& app, Context& ctx) {
  auto a = std::make_shared<TwinArgs>();
  auto* tw = app.add_subcommand("twin", "the twin without hardware");
  tw->require_subcommand(1);
  auto* predict = tw->add_subcommand("predict", "β(λ) the instrument would report");
  predict->add_option("--bsdf", a->bsdf);
  predict->add_option("--sample", a->sample);
  predict->add_option("--geometry", a->geometries);
  predict->add_option("--grid", a->grids);
  predict->add_option("--wavelengths", a->wavelengths);
  predict->callback([&ctx, a] {
    ctx.action = [a](Session& s) {
      json p{{"wavelengths", a->wavelengths}};
      if (!a->bsdf.empty()) p["bsdf"] = a->bsdf;
      if (!a->sample.empty()) p["sample"] = a->sample;
      if (!a->geometries.empty()) p["geometries"] = a->geometries;
      if (!a->grids.empty()) p["grids"] = a->grids;
      const auto r = s.call("twin.predict", p);
      print(s.options(), r, [&] {
        Table t({"θi", "θr", "β(first λ)", "β(last λ)", "±se max", "converged"});
        for (const auto& x : r["predictions"]) {
          double se = 0;
          for (const auto& v : x["std_error"]) se = std::max(se, v.get<double>());
          t.add({cell(x["geometry"]["theta_i"]), cell(x["geometry"]["theta_r"]),
                 cell(x["radiance_factor"].front()), cell(x["radiance_factor"].back()), cell(json(se)),
                 cell(x["converged"])});
        }
        std::cout << t.render();
      });
      return 0;
    };
  });
}

}  // namespace gonio::daemon::ctl
