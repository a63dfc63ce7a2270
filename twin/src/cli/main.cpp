// gonio-twin: the digital twin of the goniometric spectrophotometer as a command-line tool.
#include <CLI/CLI.hpp>

#include "cli/common.hpp"
#include "cli/output.hpp"
#include "gonio/proto/version.hpp"

int main(int argc, char** argv) {
  using namespace gonio::twin::cli;
  CLI::App app{"gonio-twin — virtual measurements with a physically based model of the "
               "goniometric spectrophotometer"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "gonio-twin " GONIO_VERSION_STRING);
  add_predict(app);
  add_error_map(app);
  add_plan(app);
  add_design(app);
  add_render(app);
  add_convert(app);
  add_fit(app);
  add_calibrate(app);
  add_material(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitUsage;
  }
  return exit_code();
}
