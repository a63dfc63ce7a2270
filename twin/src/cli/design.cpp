// gonio-twin design: an adaptive scan proposed offline, next to the uniform grid.
//
// A virtual sample (--bsdf; by default the model at its start values: the prior) is
// measured through the twin with Gaussian noise, once on every candidate and once the way
// goniod's adaptive loop would measure it; the output compares points, instrument time and
// what each determines (twin/design.md).
#include <iostream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/common.hpp"
#include "cli/output.hpp"
#include "cli/progress.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"
#include "gonio/twin/design.hpp"

namespace gonio::twin::cli {
namespace {

struct DesignCliOptions {
  std::string model;
  bool curve = false;
  std::vector<std::string> grids;
  double target_rel_u = 0.05;
  double tolerance = 0.01;
  int max_points = 50;
  double noise_rel = 0.005, noise_abs = 0.0005;
  std::string noise_of;
  ScanTiming timing;
  std::uint64_t fit_samples = 1u << 13;
  bool exact_model = false;
  double max_cell_share = ParameterDesignOptions{}.max_cell_share;
  bool json = false;
};

void print_run(const char* label, const DesignRun& r) {
  std::cout << fmt::format("{:<9} {:>4} points  {:>7.0f} s", label, r.chosen.size(), r.seconds);
  for (const auto& p : r.status.parameters)
    std::cout << fmt::format("  {} = {} ({:.2g} %)", p.name, text::format_measured(p.value, p.u),
                             100 * p.u / std::max(std::abs(p.value), 1e-300));
  if (r.status.estimated_error && label[0] == 'a')
    std::cout << fmt::format("  estimated error {:.2f} %", 100 * *r.status.estimated_error);
  std::cout << '\n';
}

}  // namespace

void add_design(CLI::App& app) {
  auto* sub = app.add_subcommand("design", "an adaptive scan proposed offline, next to the uniform grid");
  auto model = std::make_shared<ModelOptions>();
  auto o = std::make_shared<DesignCliOptions>();
  model->add_to(*sub, false);
  sub->add_option("--model", o->model, "parameters mode: a BSDF spec with '?' marks, e.g. conductor:alpha=?");
  sub->add_flag("--curve", o->curve, "curve mode: no model, refine the interpolated curve");
  sub->add_option("--grid", o->grids, "candidate geometries (grid syntax, repeatable)")->required();
  sub->add_option("--target-rel-u", o->target_rel_u, "parameters mode: stop at this relative u")
      ->capture_default_str();
  auto* curve_error =
      sub->add_option("--curve-error", o->tolerance, "curve mode: stop at this estimated relative error")
          ->capture_default_str();
  // The old name: --tolerance is a sample's acceptance limit everywhere else (gonioctl).
  auto* old_name = sub->add_option("--tolerance", o->tolerance)->group("");
  sub->add_option("--max-points", o->max_points, "at most this many points")->capture_default_str();
  sub->add_option("--noise-rel", o->noise_rel, "virtual readings' relative noise (k = 1)")->capture_default_str();
  sub->add_option("--noise-abs", o->noise_abs, "virtual readings' absolute noise in β (k = 1)")
      ->capture_default_str();
  sub->add_option("--noise-of", o->noise_of,
                  "virtual readings' u per candidate from a scan of the same candidates (scan.export JSON), "
                  "instead of --noise-rel and --noise-abs");
  sub->add_option("--speed", o->timing.speed_deg_s, "arm speed, °/s")->capture_default_str();
  sub->add_option("--settle", o->timing.settle_s, "settling after a move, s")->capture_default_str();
  sub->add_option("--reading", o->timing.reading_s, "reading time per point, s")->capture_default_str();
  sub->add_option("--fit-samples", o->fit_samples, "twin paths per geometry in the refits")->capture_default_str();
  sub->add_flag("--exact-model", o->exact_model,
                "parameters mode: choose as if the model described the sample exactly everywhere (no model u by region, no spreading once it misfits)");
  sub->add_option("--max-cell-share", o->max_cell_share,
                  "parameters mode: the largest share of the information one seed's cell may give (1: no rule)")
      ->capture_default_str();
  sub->add_flag("--json", o->json, "JSON output");
  sub->callback([model, o, old_name, curve_error] {
    exit_code() = guarded([&] {
      if (old_name->count() > 0 && curve_error->count() > 0)
        throw Error::invalid("tolerance", "give --curve-error alone (--tolerance is its old name)");
      if (old_name->count() > 0) std::cerr << "gonio-twin design: --tolerance is now --curve-error\n";
      if (o->curve == !o->model.empty())
        throw Error::invalid("model", "give either --model SPEC (parameters mode) or --curve");
      std::vector<Geometry> candidates;
      for (const auto& g : o->grids)
        for (const auto& x : parse_geometry_grid(g)) candidates.push_back(x);
      DesignStudyOptions so;
      so.truth = model->bsdf;
      so.noise_rel = o->noise_rel;
      so.noise_abs = o->noise_abs;
      if (!o->noise_of.empty()) so.noise_of = load_measured(o->noise_of);
      so.seed = model->seed;
      so.max_points = o->max_points;
      so.measurement = model->estimator_options();
      so.parameters.target_rel_u = o->target_rel_u;
      so.parameters.timing = o->timing;
      so.parameters.threads = model->threads;
      so.parameters.fit.samples = o->fit_samples;
      so.parameters.fit.threads = model->threads;
      if (o->exact_model) {
        so.parameters.model_trust = {.near_specular = 0, .per_10deg = 0, .grazing_deg = 90, .grazing_factor = 1};
        so.parameters.spread_on_misfit = false;
      }
      so.parameters.max_cell_share = o->max_cell_share;
      so.curve.tolerance = o->tolerance;
      so.curve.timing = o->timing;
      const auto study = [&] {
        Ticker ticker("design");  // erased before the result is printed
        ticker.step(fmt::format("studying {} candidates", candidates.size()));
        return study_design(o->model, candidates, model->grid(), model->load_profile(), so);
      }();
      if (o->json) {
        std::cout << study.to_json(candidates).dump(2) << '\n';
        return kExitOk;
      }
      print_run("uniform", study.uniform);
      print_run("adaptive", study.adaptive);
      std::cout << fmt::format("adaptive: {} ({:.0f} % of the points, {:.0f} % of the time); slowest choice {:.2f} s\n",
                               to_text(study.adaptive.status.state),
                               100.0 * static_cast<double>(study.adaptive.chosen.size()) / static_cast<double>(candidates.size()),
                               100 * study.adaptive.seconds / std::max(study.uniform.seconds, 1e-9),
                               study.adaptive.choice_seconds_max);
      if (study.error_vs_dense)
        std::cout << fmt::format("interpolated adaptive curve vs the dense one: {:.2f} %, vs the truth: {:.2f} % "
                                 "(beyond k·u)\n", 100 * *study.error_vs_dense, 100 * *study.error_vs_truth);
      for (const auto& w : study.adaptive.status.warnings) std::cout << "warning: " << w << '\n';
      std::cout << "geometries:";
      for (const auto c : study.adaptive.chosen) std::cout << ' ' << candidates[c].to_string();
      std::cout << '\n';
      return kExitOk;
    });
  });
}

}  // namespace gonio::twin::cli
