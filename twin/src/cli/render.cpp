// gonio-twin render: spheres side by side — the true BSDF, its virtual measurement and,
// with --corrected, the instrument-corrected table — each rendered to the same per-pixel
// noise, with the CIEDE2000 map of each against the true one (twin/rendering.md).
#include <chrono>
#include <ctime>
#include <filesystem>
#include <iostream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/common.hpp"
#include "cli/output.hpp"
#include "cli/progress.hpp"
#include "gonio/proto/enum_text.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/twin/render.hpp"
#include "gonio/twin/virtual_measurement.hpp"

namespace gonio::twin::cli {
namespace {

// --environment: KIND, KIND:LEVEL, or a LEVEL alone (a uniform environment, as before).
void parse_environment(const std::string& text, Lighting& l) {
  const auto bad = [&] {
    return Error::invalid("--environment",
                          fmt::format("'{}': expected none, uniform, sky or studio, optionally "
                                      "followed by :LEVEL (0 to 100), or a level alone",
                                      text));
  };
  const auto level = [&](const std::string& s) {
    std::size_t used = 0;
    double v = 0;
    try {
      v = std::stod(s, &used);
    } catch (const std::exception&) {
      throw bad();
    }
    if (used != s.size()) throw bad();
    if (!(v >= 0 && v <= 100)) throw Error::out_of_range("--environment", v, 0, 100);
    return v;
  };
  const auto colon = text.find(':');
  const std::string kind = text.substr(0, colon);
  if (!kind.empty() && (std::isdigit(static_cast<unsigned char>(kind[0])) || kind[0] == '.')) {
    if (colon != std::string::npos) throw bad();
    l.environment = EnvironmentKind::uniform;
    l.environment_level = level(kind);
    return;
  }
  const auto k = from_text<EnvironmentKind>(kind);
  if (!k) throw bad();
  l.environment = *k;
  if (colon != std::string::npos) l.environment_level = level(text.substr(colon + 1));
}

nlohmann::json noise_json(const NoiseReport& n, double target) {
  return {{"target_rel_se", target},          {"lit_pixels", n.lit_pixels},
          {"median_rel_se", n.median_rel_se}, {"p95_rel_se", n.p95_rel_se},
          {"max_rel_se", n.max_rel_se},       {"converged_fraction", n.converged_fraction},
          {"mean_samples", n.mean_samples}};
}

double cpu_seconds_since(std::clock_t start) {
  return static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC;
}

// Everything `render` is given, beside the twin's own options.
struct RenderCli {
  ModelOptions model;
  RenderOptions render;
  std::string output = "spheres.png";
  std::string environment = "sky:0.25";
  std::string corrected;
  double theta_step = 5, radial_step = 0.5, phi_step = 15;  // the measurement grid, °
  std::string tone = "clip";
  bool grey = false;
  bool json = false;

  RenderCli() {
    // The measurement only has to be below what the eye sees in a picture.
    model.rel_se = 5e-3;
  }
};

// The scene: the spheres' size, the key light and the environment.
void add_scene_options(CLI::App& sub, RenderCli& o) {
  sub.add_option("--size", o.render.size, "pixels per panel")
      ->check(CLI::Range(16, 4096))
      ->capture_default_str();
  sub.add_option("--light-theta", o.render.lighting.light_theta, "key light: angle from the view direction, °")
      ->check(CLI::Range(0.0, 180.0))
      ->capture_default_str();
  sub.add_option("--light-phi", o.render.lighting.light_phi, "key light: azimuth in the image plane, °")
      ->check(CLI::Range(-360.0, 360.0))
      ->capture_default_str();
  sub.add_option("--light-size", o.render.lighting.light_size,
                 "key light: angular radius of its disc, ° (0: a point light)")
      ->check(CLI::Range(0.0, 45.0))
      ->capture_default_str();
  sub.add_option("--environment", o.environment,
                 "none, uniform, sky or studio, optionally :LEVEL (0 to 100); a number alone "
                 "is a uniform environment of that level")
      ->capture_default_str();
}

// The renderer's noise: its per-pixel target and sample counts.
void add_noise_options(CLI::App& sub, RenderCli& o) {
  sub.add_option("--pixel-rel-se", o.render.rel_se, "per-pixel target: standard error / luminance (lit pixels)")
      ->check(CLI::Range(1e-4, 0.5))
      ->capture_default_str();
  sub.add_option("--spp", o.render.min_samples, "samples per pixel per batch (and at least)")
      ->check(CLI::Range(2, 1 << 16))
      ->capture_default_str();
  sub.add_option("--max-spp", o.render.max_samples, "samples per pixel at most")
      ->check(CLI::Range(2, 1 << 20))
      ->capture_default_str();
}

// The picture: exposure, tone map, colour and the ΔE00 scale.
void add_picture_options(CLI::App& sub, RenderCli& o) {
  sub.add_option("--exposure", o.render.exposure, "linear exposure before tone mapping")
      ->check(CLI::Range(1e-6, 1e6))
      ->capture_default_str();
  sub.add_option("--tone-map", o.tone, "clip or reinhard")
      ->check(CLI::IsMember({"clip", "reinhard"}))
      ->capture_default_str();
  sub.add_flag("--grey", o.grey, "luminance only (grey spheres) instead of colour");
  sub.add_option("--delta-e-max", o.render.delta_e_max, "top of the ΔE00 colour scale")
      ->check(CLI::Range(0.1, 100.0))
      ->capture_default_str();
}

// The virtual measurement's grid about the specular direction.
void add_grid_options(CLI::App& sub, RenderCli& o) {
  sub.add_option("--theta-step", o.theta_step, "measurement grid: θi step, ° (0.5 to 45)")
      ->check(CLI::Range(0.5, 45.0))
      ->capture_default_str();
  sub.add_option("--radial-step", o.radial_step,
                 "measurement grid: first step away from the specular direction, ° (0.05 to 10)")
      ->check(CLI::Range(0.05, 10.0))
      ->capture_default_str();
  sub.add_option("--phi-step", o.phi_step,
                 "measurement grid: azimuth step about the specular direction, ° (1 to 90)")
      ->check(CLI::Range(1.0, 90.0))
      ->capture_default_str();
}

// What one run measured, rendered and spent.
struct RenderRun {
  RenderOptions opts;
  std::size_t geometries = 0;
  std::vector<std::string> names;  // true, measured[, corrected]
  Comparison result;
  double total = 0, total_cpu = 0, measure_s = 0, measure_cpu = 0, render_cpu = 0;
};

void report(const RenderCli& o, const RenderRun& run) {
  const auto& r = run.result;
  for (std::size_t k = 0; k < r.spheres.size(); ++k) {
    const auto& n = r.spheres[k].noise;
    std::cerr << fmt::format(
        "{}: {} lit pixels, rel. s.e. median {:.2f} %, p95 {:.2f} %, max {:.2f} % "
        "({:.1f} % at or below {:g} %), {:.0f} samples/pixel, {:.1f} s ({:.1f} s CPU)\n",
        run.names[k], n.lit_pixels, 100 * n.median_rel_se, 100 * n.p95_rel_se,
        100 * n.max_rel_se, 100 * n.converged_fraction, 100 * run.opts.rel_se, n.mean_samples,
        r.spheres[k].seconds, r.spheres[k].cpu_seconds);
  }
  std::cerr << fmt::format(
      "time: {:.1f} s wall, {:.1f} s CPU (measurement {:.1f} s wall, {:.1f} s CPU; "
      "spheres and maps {:.1f} s CPU)\n",
      run.total, run.total_cpu, run.measure_s, run.measure_cpu, run.render_cpu);
  if (!o.json) {
    for (std::size_t k = 0; k < r.maps.size(); ++k) {
      const auto& s = r.maps[k].stats;
      std::cout << fmt::format(
          "ΔE00 {} vs {}: mean {:.3f} (noise alone ≈ {:.3f}), p95 {:.3f}, max {:.3f} ({} "
          "pixels)\n",
          run.names[k + 1], run.names[0], s.mean, s.noise_mean, s.p95, s.max, s.pixels);
    }
    std::cout << fmt::format("wrote {} ({}, {:.1f} s, measurement {:.1f} s)\n", o.output,
                             file_size_text(o.output), run.total, run.measure_s);
    return;
  }
  nlohmann::json j;
  j["output"] = o.output;
  j["bytes"] = std::filesystem::file_size(o.output);
  j["size"] = run.opts.size;
  j["seconds"] = run.total;
  j["cpu_seconds"] = run.total_cpu;
  j["render_cpu_seconds"] = run.render_cpu;
  j["measurement"] = {{"geometries", run.geometries},
                      {"seconds", run.measure_s},
                      {"cpu_seconds", run.measure_cpu},
                      {"theta_step", o.theta_step},
                      {"radial_step", o.radial_step},
                      {"phi_step", o.phi_step}};
  j["spheres"] = nlohmann::json::array();
  for (std::size_t k = 0; k < r.spheres.size(); ++k)
    j["spheres"].push_back({{"name", run.names[k]},
                            {"seconds", r.spheres[k].seconds},
                            {"cpu_seconds", r.spheres[k].cpu_seconds},
                            {"noise", noise_json(r.spheres[k].noise, run.opts.rel_se)}});
  j["delta_e"] = nlohmann::json::array();
  for (std::size_t k = 0; k < r.maps.size(); ++k) {
    const auto& s = r.maps[k].stats;
    j["delta_e"].push_back({{"reference", run.names[0]}, {"other", run.names[k + 1]},
                            {"pixels", s.pixels}, {"mean", s.mean}, {"p95", s.p95},
                            {"max", s.max}, {"noise_mean", s.noise_mean}});
  }
  std::cout << j.dump(2) << '\n';
}

int run_render(const RenderCli& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto c_start = std::clock();
  Ticker ticker("render");
  RenderRun run;
  auto& opts = run.opts;
  opts = o.render;
  parse_environment(o.environment, opts.lighting);
  opts.tone_map = parse_enum<ToneMap>(o.tone, "--tone-map");
  opts.color = !o.grey;
  opts.seed = o.model.seed;
  opts.threads = o.model.threads;
  if (opts.max_samples < opts.min_samples)
    throw Error::invalid("--max-spp", fmt::format("{} is below --spp {}", opts.max_samples,
                                                  opts.min_samples));
  opts.validate();
  const auto twin = o.model.make_twin();
  BsdfPtr corrected_bsdf;
  if (!o.corrected.empty()) corrected_bsdf = load_bsdf_file(o.corrected, twin.wavelengths());

  const auto grid = specular_measurement_grid(o.theta_step, o.radial_step, o.phi_step);
  run.geometries = specular_geometries(grid).geometries.size();
  std::cerr << fmt::format("measuring {} geometries ...\n", run.geometries);
  ticker.step(fmt::format("measuring {} geometries", run.geometries));
  const auto tm = std::chrono::steady_clock::now();
  const auto c_measure = std::clock();
  TabulatedParts parts;
  // First check after 32 points per replicate instead of 64: most geometries are
  // already at the target there (what decides it is the replicates' spread), and a
  // second seed differs from the first by what the reported errors say.
  auto estimator = o.model.estimator_options();
  estimator.first_points = 32;
  parts.brdf = measure_specular(twin, grid, estimator, o.model.threads);
  parts.name = "virtually measured " + twin.sample().spec();
  const TabulatedBsdf measured(twin.wavelengths(), std::move(parts),
                               "virtually measured " + twin.sample().spec());
  run.measure_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - tm).count();
  // Process CPU time (every thread) per phase: on a shared machine the honest figure.
  run.measure_cpu = cpu_seconds_since(c_measure);

  std::vector<const Bsdf*> bsdfs{&twin.sample(), &measured};
  run.names = {"true", "measured"};
  std::vector<std::string> captions{
      "true BSDF", fmt::format("measured ({:g}°/{:g}°/{:g}° grid)", o.theta_step,
                               o.radial_step, o.phi_step)};
  if (corrected_bsdf) {
    bsdfs.push_back(corrected_bsdf.get());
    run.names.emplace_back("corrected");
    captions.emplace_back("corrected");
  }
  ticker.step("rendering the spheres and ΔE00 maps");
  const auto c_render = std::clock();
  run.result = render_comparison(bsdfs, captions, opts);
  run.render_cpu = cpu_seconds_since(c_render);
  ticker.step("writing " + o.output);
  write_png(run.result.image, o.output);
  run.total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  run.total_cpu = cpu_seconds_since(c_start);
  report(o, run);
  return kExitOk;
}

}  // namespace

void add_render(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "render", "PNG of spheres (true, virtually measured, corrected BSDF) with ΔE00 maps");
  auto o = std::make_shared<RenderCli>();
  o->model.add_to(*sub);
  sub->add_option("--output", o->output, "PNG file")->capture_default_str();
  sub->add_option("--corrected", o->corrected,
                  "instrument-corrected table (what `fit --corrected` writes: .bsdf, .ssdd): "
                  "a third sphere and a second ΔE00 map");
  add_scene_options(*sub, *o);
  add_noise_options(*sub, *o);
  add_picture_options(*sub, *o);
  add_grid_options(*sub, *o);
  sub->add_flag("--json", o->json, "JSON summary on stdout (noise, ΔE00 statistics, times)");
  sub->callback([o] { exit_code() = guarded([&] { return run_render(*o); }); });
}

}  // namespace gonio::twin::cli
