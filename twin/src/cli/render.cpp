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

}  // namespace

void add_render(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "render", "PNG of spheres (true, virtually measured, corrected BSDF) with ΔE00 maps");
  auto model = std::make_shared<ModelOptions>();
  // The measurement only has to be below what the eye sees in a picture.
  model->rel_se = 5e-3;
  model->replicates = 16;
  auto ro = std::make_shared<RenderOptions>();
  auto output = std::make_shared<std::string>("spheres.png");
  auto environment = std::make_shared<std::string>("sky:0.25");
  auto corrected = std::make_shared<std::string>();
  auto theta_step = std::make_shared<double>(5.0);
  auto radial_step = std::make_shared<double>(0.5);
  auto phi_step = std::make_shared<double>(15.0);
  auto tone = std::make_shared<std::string>("clip");
  auto grey = std::make_shared<bool>(false);
  auto json = std::make_shared<bool>(false);
  model->add_to(*sub);
  sub->add_option("--output", *output, "PNG file")->capture_default_str();
  sub->add_option("--corrected", *corrected,
                  "instrument-corrected table (what `fit --corrected` writes: .bsdf, .ssdd): "
                  "a third sphere and a second ΔE00 map");
  sub->add_option("--size", ro->size, "pixels per panel")
      ->check(CLI::Range(16, 4096))
      ->capture_default_str();
  sub->add_option("--light-theta", ro->lighting.light_theta,
                  "key light: angle from the view direction, °")
      ->check(CLI::Range(0.0, 180.0))
      ->capture_default_str();
  sub->add_option("--light-phi", ro->lighting.light_phi, "key light: azimuth in the image plane, °")
      ->check(CLI::Range(-360.0, 360.0))
      ->capture_default_str();
  sub->add_option("--light-size", ro->lighting.light_size,
                  "key light: angular radius of its disc, ° (0: a point light)")
      ->check(CLI::Range(0.0, 45.0))
      ->capture_default_str();
  sub->add_option("--environment", *environment,
                  "none, uniform, sky or studio, optionally :LEVEL (0 to 100); a number alone "
                  "is a uniform environment of that level")
      ->capture_default_str();
  sub->add_option("--pixel-rel-se", ro->rel_se,
                  "per-pixel target: standard error / luminance (lit pixels)")
      ->check(CLI::Range(1e-4, 0.5))
      ->capture_default_str();
  sub->add_option("--spp", ro->min_samples, "samples per pixel per batch (and at least)")
      ->check(CLI::Range(2, 1 << 16))
      ->capture_default_str();
  sub->add_option("--max-spp", ro->max_samples, "samples per pixel at most")
      ->check(CLI::Range(2, 1 << 20))
      ->capture_default_str();
  sub->add_option("--exposure", ro->exposure, "linear exposure before tone mapping")
      ->check(CLI::Range(1e-6, 1e6))
      ->capture_default_str();
  sub->add_option("--tone-map", *tone, "clip or reinhard")
      ->check(CLI::IsMember({"clip", "reinhard"}))
      ->capture_default_str();
  sub->add_flag("--grey", *grey, "luminance only (grey spheres) instead of colour");
  sub->add_option("--delta-e-max", ro->delta_e_max, "top of the ΔE00 colour scale")
      ->check(CLI::Range(0.1, 100.0))
      ->capture_default_str();
  sub->add_option("--theta-step", *theta_step, "measurement grid: θi step, ° (0.5 to 45)")
      ->check(CLI::Range(0.5, 45.0))
      ->capture_default_str();
  sub->add_option("--radial-step", *radial_step,
                  "measurement grid: first step away from the specular direction, ° (0.05 to 10)")
      ->check(CLI::Range(0.05, 10.0))
      ->capture_default_str();
  sub->add_option("--phi-step", *phi_step,
                  "measurement grid: azimuth step about the specular direction, ° (1 to 90)")
      ->check(CLI::Range(1.0, 90.0))
      ->capture_default_str();
  sub->add_flag("--json", *json, "JSON summary on stdout (noise, ΔE00 statistics, times)");
  sub->callback([=] {
    exit_code() = guarded([&] {
      const auto t0 = std::chrono::steady_clock::now();
      const auto c_start = std::clock();
      Ticker ticker("render");
      auto opts = *ro;
      parse_environment(*environment, opts.lighting);
      opts.tone_map = parse_enum<ToneMap>(*tone, "--tone-map");
      opts.color = !*grey;
      opts.seed = model->seed;
      opts.threads = model->threads;
      if (opts.max_samples < opts.min_samples)
        throw Error::invalid("--max-spp", fmt::format("{} is below --spp {}", opts.max_samples,
                                                      opts.min_samples));
      opts.validate();
      const auto twin = model->make_twin();
      BsdfPtr corrected_bsdf;
      if (!corrected->empty()) corrected_bsdf = load_bsdf_file(*corrected, twin.wavelengths());

      const auto grid = specular_measurement_grid(*theta_step, *radial_step, *phi_step);
      const auto n_geo = specular_geometries(grid).geometries.size();
      std::cerr << fmt::format("measuring {} geometries ...\n", n_geo);
      ticker.step(fmt::format("measuring {} geometries", n_geo));
      const auto tm = std::chrono::steady_clock::now();
      const auto c_measure = std::clock();
      TabulatedParts parts;
      // First check after 32 points per replicate instead of 64: most geometries are
      // already at the target there (what decides it is the replicates' spread), and a
      // second seed differs from the first by what the reported errors say.
      auto estimator = model->estimator_options();
      estimator.first_points = 32;
      parts.brdf = measure_specular(twin, grid, estimator, model->threads);
      parts.name = "virtually measured " + twin.sample().spec();
      const TabulatedBsdf measured(twin.wavelengths(), std::move(parts),
                                   "virtually measured " + twin.sample().spec());
      const double measure_s =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - tm).count();
      // Process CPU time (every thread) per phase: on a shared machine the honest figure.
      const double measure_cpu = cpu_seconds_since(c_measure);

      std::vector<const Bsdf*> bsdfs{&twin.sample(), &measured};
      std::vector<std::string> names{"true", "measured"};
      std::vector<std::string> captions{
          "true BSDF", fmt::format("measured ({:g}°/{:g}°/{:g}° grid)", *theta_step,
                                   *radial_step, *phi_step)};
      if (corrected_bsdf) {
        bsdfs.push_back(corrected_bsdf.get());
        names.emplace_back("corrected");
        captions.emplace_back("corrected");
      }
      ticker.step("rendering the spheres and ΔE00 maps");
      const auto c_render = std::clock();
      const auto r = render_comparison(bsdfs, captions, opts);
      const double render_cpu = cpu_seconds_since(c_render);
      ticker.step("writing " + *output);
      write_png(r.image, *output);
      const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const double total_cpu = cpu_seconds_since(c_start);

      for (std::size_t k = 0; k < r.spheres.size(); ++k) {
        const auto& n = r.spheres[k].noise;
        std::cerr << fmt::format(
            "{}: {} lit pixels, rel. s.e. median {:.2f} %, p95 {:.2f} %, max {:.2f} % "
            "({:.1f} % at or below {:g} %), {:.0f} samples/pixel, {:.1f} s ({:.1f} s CPU)\n",
            names[k], n.lit_pixels, 100 * n.median_rel_se, 100 * n.p95_rel_se,
            100 * n.max_rel_se, 100 * n.converged_fraction, 100 * opts.rel_se, n.mean_samples,
            r.spheres[k].seconds, r.spheres[k].cpu_seconds);
      }
      std::cerr << fmt::format(
          "time: {:.1f} s wall, {:.1f} s CPU (measurement {:.1f} s wall, {:.1f} s CPU; "
          "spheres and maps {:.1f} s CPU)\n",
          total, total_cpu, measure_s, measure_cpu, render_cpu);
      if (*json) {
        nlohmann::json j;
        j["output"] = *output;
        j["bytes"] = std::filesystem::file_size(*output);
        j["size"] = opts.size;
        j["seconds"] = total;
        j["cpu_seconds"] = total_cpu;
        j["render_cpu_seconds"] = render_cpu;
        j["measurement"] = {{"geometries", n_geo},
                            {"seconds", measure_s},
                            {"cpu_seconds", measure_cpu},
                            {"theta_step", *theta_step},
                            {"radial_step", *radial_step},
                            {"phi_step", *phi_step}};
        j["spheres"] = nlohmann::json::array();
        for (std::size_t k = 0; k < r.spheres.size(); ++k)
          j["spheres"].push_back({{"name", names[k]},
                                  {"seconds", r.spheres[k].seconds},
                                  {"cpu_seconds", r.spheres[k].cpu_seconds},
                                  {"noise", noise_json(r.spheres[k].noise, opts.rel_se)}});
        j["delta_e"] = nlohmann::json::array();
        for (std::size_t k = 0; k < r.maps.size(); ++k) {
          const auto& s = r.maps[k].stats;
          j["delta_e"].push_back({{"reference", names[0]}, {"other", names[k + 1]},
                                  {"pixels", s.pixels}, {"mean", s.mean}, {"p95", s.p95},
                                  {"max", s.max}, {"noise_mean", s.noise_mean}});
        }
        std::cout << j.dump(2) << '\n';
      } else {
        for (std::size_t k = 0; k < r.maps.size(); ++k) {
          const auto& s = r.maps[k].stats;
          std::cout << fmt::format(
              "ΔE00 {} vs {}: mean {:.3f} (noise alone ≈ {:.3f}), p95 {:.3f}, max {:.3f} ({} "
              "pixels)\n",
              names[k + 1], names[0], s.mean, s.noise_mean, s.p95, s.max, s.pixels);
        }
        std::cout << fmt::format("wrote {} ({}, {:.1f} s, measurement {:.1f} s)\n", *output,
                                 file_size_text(*output), total, measure_s);
      }
      return kExitOk;
    });
  });
}

}  // namespace gonio::twin::cli
