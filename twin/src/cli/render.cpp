// gonio-twin render: two spheres side by side — the true BSDF on the left, the virtually
// measured (tabulated) BSDF on the right — as in the founding paper's visual analysis.
#include <iostream>

#include <fmt/format.h>

#include "cli/common.hpp"
#include "cli/output.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/twin/render.hpp"
#include "gonio/twin/virtual_measurement.hpp"

namespace gonio::twin::cli {

void add_render(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "render", "PNG of spheres with the true (left) and virtually measured (right) BSDF");
  auto model = std::make_shared<ModelOptions>();
  auto ro = std::make_shared<RenderOptions>();
  auto output = std::make_shared<std::string>("spheres.png");
  auto theta_step = std::make_shared<double>(2.5);
  auto phi_step = std::make_shared<double>(15.0);
  model->add_to(*sub);
  sub->add_option("--output", *output, "PNG file")->capture_default_str();
  sub->add_option("--size", ro->size, "pixels per sphere")->capture_default_str();
  sub->add_option("--light-theta", ro->light_theta, "light angle from the view direction, °")
      ->capture_default_str();
  sub->add_option("--light-phi", ro->light_phi, "light azimuth in the image plane, °")
      ->capture_default_str();
  sub->add_option("--environment", ro->environment, "uniform environment level")
      ->capture_default_str();
  sub->add_option("--spp", ro->samples, "samples per pixel")->capture_default_str();
  sub->add_option("--exposure", ro->exposure, "linear exposure")->capture_default_str();
  sub->add_option("--theta-step", *theta_step, "measurement grid: θi and θo step, °")
      ->capture_default_str();
  sub->add_option("--phi-step", *phi_step, "measurement grid: φo step, °")->capture_default_str();
  sub->callback([=] {
    exit_code() = guarded([&] {
      ro->validate();
      const auto twin = model->make_twin();
      const auto grid = measurement_grid(*theta_step, *phi_step);
      std::cerr << fmt::format("measuring {} geometries ...\n",
                               grid.theta_i.size() * grid.theta_o.size() * grid.phi_o.size());
      const auto measured =
          measure_tabulated(twin, grid, model->estimator_options(), model->threads);
      auto opts = *ro;
      opts.seed = model->seed;
      opts.threads = model->threads;
      opts.left_caption = "true BSDF";
      opts.right_caption = fmt::format("measured, {}°/{}° grid", *theta_step, *phi_step);
      const auto r = render_spheres(twin.sample(), *measured, opts);
      write_png(r.image, *output);
      std::cout << fmt::format("wrote {}\n", *output);
      return kExitOk;
    });
  });
}

}  // namespace gonio::twin::cli
