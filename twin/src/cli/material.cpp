// gonio-twin material: a fitted or catalogued BSDF spec written for a renderer — Mitsuba 3
// scene XML, glTF 2.0 (fitted, with its ΔE00) or a MERL table (with its round trip) —
// (twin/material.md).
#include <chrono>
#include <iostream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/common.hpp"
#include "cli/output.hpp"
#include "cli/progress.hpp"
#include "gonio/proto/enum_text.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/twin/material.hpp"

namespace gonio::twin::cli {
namespace {

nlohmann::json summary_json(const material::DeltaESummary& s) {
  return {{"mean", s.mean}, {"p95", s.p95}, {"max", s.max}, {"samples", s.samples}};
}

nlohmann::json report_json(const material::ExportReport& r, const std::string& output) {
  nlohmann::json j{{"format", to_text(r.format)}, {"output", output}, {"spec", r.spec}, {"notes", r.notes}};
  if (r.gltf) {
    const auto& g = *r.gltf;
    const auto& m = g.material;
    j["gltf"] = {{"spec", g.spec},
                 {"base_color", m.base_color},
                 {"metallic", m.metallic},
                 {"roughness", m.roughness},
                 {"ior", m.ior},
                 {"specular", m.specular},
                 {"clearcoat", m.clearcoat},
                 {"clearcoat_roughness", m.clearcoat_roughness},
                 {"start", g.start},
                 {"delta_e_geometries", summary_json(g.geometries)}};
    if (g.studio) {
      j["gltf"]["delta_e_studio"] = summary_json(*g.studio);
      j["gltf"]["delta_e_studio"]["noise_mean"] = g.studio_noise_mean;
    }
  }
  if (r.merl)
    j["merl"] = {{"max_rel", r.merl->max_rel}, {"mean_rel", r.merl->mean_rel},
                 {"theta_i", r.merl->theta_i}, {"theta_r", r.merl->theta_r}};
  return j;
}

void print_report(const material::ExportReport& r, const std::string& output, double secs) {
  if (r.gltf) {
    const auto& g = *r.gltf;
    std::cout << fmt::format("glTF approximation: {}\n", g.spec);
    std::cout << fmt::format("ΔE00 over {} geometries: mean {:.2f}, p95 {:.2f}, max {:.2f}\n",
                             g.geometries.samples, g.geometries.mean, g.geometries.p95, g.geometries.max);
    if (g.studio)
      std::cout << fmt::format("ΔE00 studio render ({} pixels): mean {:.2f} (noise {:.2f}), p95 {:.2f}, max {:.2f}\n",
                               g.studio->samples, g.studio->mean, g.studio_noise_mean, g.studio->p95,
                               g.studio->max);
  }
  if (r.merl)
    std::cout << fmt::format("MERL round trip: largest relative difference {:.3f} % (θi = {:g}°, θr = {:g}°), "
                             "mean {:.4f} %\n", 100 * r.merl->max_rel, r.merl->theta_i, r.merl->theta_r,
                             100 * r.merl->mean_rel);
  for (const auto& n : r.notes) std::cout << "note: " << n << '\n';
  std::cout << fmt::format("wrote {} ({}, {:.1f} s)\n", output, file_size_text(output), secs);
}

}  // namespace

void add_material(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "material", "write a BSDF spec for a renderer: Mitsuba 3 XML, glTF 2.0 (fitted, with its "
                  "ΔE00) or a MERL table");
  auto bsdf = std::make_shared<std::string>();
  auto format = std::make_shared<std::string>();
  auto output = std::make_shared<std::string>();
  auto wavelengths = std::make_shared<std::string>("400:700:10");
  auto opts = std::make_shared<material::GltfFitOptions>();
  auto json = std::make_shared<bool>(false);
  auto no_render = std::make_shared<bool>(false);
  opts->check.size = 160;
  opts->check.lighting.environment = EnvironmentKind::studio;
  opts->check.lighting.environment_level = 0.25;
  sub->add_option("--bsdf", *bsdf, "BSDF spec string or @file (a fitted or catalogued material)")->required();
  sub->add_option("--format", *format, "mitsuba, gltf or merl")
      ->check(CLI::IsMember({"mitsuba", "gltf", "merl"}))
      ->required();
  sub->add_option("--output", *output, "output file (.xml, .gltf, .binary)")->required();
  sub->add_option("--wavelengths", *wavelengths, "wavelength grid the spec is built and compared on")
      ->capture_default_str();
  sub->add_option("--size", opts->check.size, "glTF: pixels of the studio render that checks the fit")
      ->capture_default_str();
  sub->add_option("--pixel-rel-se", opts->check.rel_se, "glTF: per-pixel noise target of that render")
      ->capture_default_str();
  sub->add_option("--threads", opts->check.threads, "worker threads (0: all cores)")->capture_default_str();
  sub->add_flag("--no-render", *no_render, "glTF: skip the studio render check (geometries only)");
  sub->add_option("--plot", opts->plot, "glTF: the material and its approximation side by side with their ΔE00 map (PNG)");
  sub->add_flag("--json", *json, "JSON summary on stdout");
  sub->callback([=] {
    exit_code() = guarded([&] {
      const auto t0 = std::chrono::steady_clock::now();
      opts->check.validate();
      opts->render_check = !*no_render;
      if (*no_render && !opts->plot.empty())
        throw Error::invalid("plot", "--plot draws the studio render, which --no-render skips");
      const auto grid = WavelengthGrid::parse(*wavelengths);
      const auto f = from_text<material::Format>(*format);
      const auto r = material::export_material(*bsdf, *f, *output, grid, *opts);
      const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (*json)
        std::cout << report_json(r, *output).dump(2) << '\n';
      else
        print_report(r, *output, secs);
      return kExitOk;
    });
  });
}

}  // namespace gonio::twin::cli
