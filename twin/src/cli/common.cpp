#include "cli/common.hpp"

#include <iostream>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/proto/spectrum.hpp"

namespace gonio::twin::cli {

void ModelOptions::add_to(CLI::App& app, bool need_bsdf) {
  auto* b = app.add_option("--bsdf", bsdf,
                           "sample BSDF: spec string (lambert:albedo=0.8, "
                           "conductor:alpha=0.05,eta=0.2,k=3.9, ...) or @file");
  if (need_bsdf) b->required();
  app.add_option("--profile", profile, "instrument profile: preset name or JSON file")
      ->capture_default_str();
  app.add_option("--wavelengths", wavelengths, "wavelength grid, e.g. 400:700:10")
      ->capture_default_str();
  app.add_option("--estimator", estimator, "rqmc or baseline")
      ->check(CLI::IsMember({"rqmc", "baseline"}))
      ->capture_default_str();
  // A command whose own default differs from the twin's (render) says so, with the twin's;
  // the others share goniod's [twin] defaults (estimator_options.hpp).
  const EstimatorOptions twin_defaults;
  const auto own = [](bool differs, auto twin_value) {
    return differs ? fmt::format(" (this command's own; the twin's and goniod's [twin] default: {})", twin_value)
                   : std::string();
  };
  app.add_option("--rel-se", rel_se,
                 "target relative standard error per channel" + own(rel_se != twin_defaults.rel_se, twin_defaults.rel_se))
      ->capture_default_str();
  app.add_option("--max-samples", max_samples,
                 "sample budget per geometry" + own(max_samples != twin_defaults.max_samples, twin_defaults.max_samples))
      ->capture_default_str();
  app.add_option("--replicates", replicates,
                 "independent randomisations (standard error)" +
                     own(replicates != twin_defaults.replicates, twin_defaults.replicates))
      ->capture_default_str();
  app.add_option("--seed", seed, "random seed (results are deterministic per seed)")
      ->capture_default_str();
  app.add_option("--threads", threads, "worker threads (0: all cores)")->capture_default_str();
  app.add_option("--calibration", calibration,
                 "override the profile's calibration: per-geometry or fixed")
      ->check(CLI::IsMember({"per-geometry", "fixed"}));
}

EstimatorOptions ModelOptions::estimator_options() const {
  EstimatorOptions o;
  o.kind = estimator == "baseline" ? EstimatorKind::baseline : EstimatorKind::rqmc;
  o.rel_se = rel_se;
  o.max_samples = max_samples;
  o.replicates = replicates;
  o.seed = seed;
  o.validate();
  return o;
}

InstrumentProfile ModelOptions::load_profile() const {
  auto p = InstrumentProfile::load(profile);
  if (calibration == "fixed") p.calibration.mode = CalibrationMode::fixed;
  if (calibration == "per-geometry") p.calibration.mode = CalibrationMode::per_geometry;
  return p;
}

WavelengthGrid ModelOptions::grid() const { return WavelengthGrid::parse(wavelengths); }

Twin ModelOptions::make_twin() const {
  const auto g = grid();
  return Twin(load_profile(), make_bsdf(bsdf, g), g);
}

void GeometryOptions::add_to(CLI::App& app) {
  app.add_option("--in", in, "incidence angle θi, degrees")->capture_default_str();
  app.add_option("--out", out, "receiving angle θr, degrees (signed; |θr| > 90 transmits)")
      ->capture_default_str();
  app.add_option("--az-in", az_in, "incidence azimuth φi, degrees")->capture_default_str();
  app.add_option("--az-out", az_out, "receiving azimuth φr, degrees")->capture_default_str();
  app.add_option("--grid", grid, "geometry grid, e.g. 'in=45;out=-80:80:1' (overrides --in/--out)");
  app.add_option("--geometry", named,
                 "named geometries, e.g. 45as15 or 45/30 (repeatable; 'astm' for the ASTM set)");
}

std::vector<Geometry> GeometryOptions::geometries() const {
  std::vector<Geometry> result;
  if (!grid.empty()) result = parse_geometry_grid(grid);
  for (const auto& name : named) {
    if (name == "astm") {
      for (const auto& [n, g] : Geometry::astm_multi_angle()) result.push_back(g);
    } else {
      result.push_back(Geometry::parse(name));
    }
  }
  if (result.empty()) {
    const Geometry g{in, az_in, out, az_out};
    g.validate();
    result.push_back(g);
  }
  return result;
}

int guarded(const std::function<int()>& body) {
  try {
    return body();
  } catch (const Error& e) {
    std::cerr << "gonio-twin: " << e.what() << '\n';
    switch (e.code()) {
      case Errc::not_found:
      case Errc::parse_error: return kExitInput;
      case Errc::io_error: return kExitOutput;
      case Errc::internal: return kExitInternal;
      default: return kExitUsage;
    }
  } catch (const std::exception& e) {
    std::cerr << "gonio-twin: internal error: " << e.what() << '\n';
    return kExitInternal;
  }
}

}  // namespace gonio::twin::cli
