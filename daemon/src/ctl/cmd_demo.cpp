// gonioctl demo: the README's main job (run_demo in demo.cpp) and its options.
#include <memory>

#include <CLI/CLI.hpp>

#include "ctl/ctl_internal.hpp"

namespace gonio::daemon::ctl {

void add_demo_commands(CLI::App& app, Context& ctx) {
  auto demo = std::make_shared<DemoOptions>();
  auto* dm = app.add_subcommand("demo", "start goniod --mock in a fresh state dir, measure a glossy sample, "
                                        "compare with the twin, plot, stop");
  dm->add_option("--demo-dir", demo->state_dir, "state dir for the demo's goniod (default: a new temporary one)");
  dm->add_option("--goniod", demo->goniod, "goniod executable (default: next to gonioctl)");
  dm->add_option("--output,-o", demo->output, "PNG plot (default: <demo-dir>/demo.png)");
  dm->add_option("--time-scale", demo->time_scale, "real seconds per virtual second of the mock's motion")
      ->check(CLI::Range(0.0, 10.0));
  dm->add_flag("--keep-serving", demo->keep_serving, "leave goniod running afterwards");
  dm->callback([&ctx, demo] {
    ctx.action = [demo](Session& s) { return run_demo(*demo, s.options()); };
  });
}

}  // namespace gonio::daemon::ctl
