// gonio-twin fit: material parameters fitted through the virtual instrument (twin/fitting.md).
#include <cmath>
#include <limits>
#include <fstream>
#include <iostream>
#include <algorithm>
#include <map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/common.hpp"
#include "cli/fit_output.hpp"
#include "cli/output.hpp"
#include "cli/progress.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"
#include "gonio/twin/bsdf_io.hpp"
#include "gonio/twin/color.hpp"
#include "gonio/twin/in_plane.hpp"
#include "gonio/twin/plot.hpp"

namespace gonio::twin::cli {

void FitCliOptions::add_to(CLI::App& app) {
  command = app.get_name();
  app.add_option("--measured", measured,
                 "measured data: goniod's scan export (.csv or .json) or a tabulated BSDF "
                 "(.bsdf IS-SA, .ssdd)")
      ->required();
  app.add_option("--profile", profile, "instrument profile: preset name or JSON file")
      ->capture_default_str();
  app.add_option("--calibration", calibration,
                 "override the profile's calibration: per-geometry or fixed")
      ->check(CLI::IsMember({"per-geometry", "fixed"}));
  samples = app.add_option("--samples", fit.samples,
                           "twin paths per geometry and evaluation (sample + reference), all spent "
                           "by every evaluation (a fixed budget, not --max-samples' ceiling)")
                ->capture_default_str();
  // The other commands' --max-samples is a ceiling that --rel-se usually stops short of; a
  // fit has no --rel-se, so the spelling is taken for its budget, with a note.
  max_samples = app.add_option("--max-samples", fit.samples)->group("");
  app.add_option("--replicates", fit.replicates, "independent randomisations (standard error)")
      ->capture_default_str();
  app.add_option("--seed", fit.seed, "random seed, the same at every evaluation")
      ->capture_default_str();
  app.add_option("--threads", fit.threads, "worker threads (0: all cores)")->capture_default_str();
  app.add_option("--max-iterations", fit.max_iterations, "Levenberg–Marquardt iterations")
      ->capture_default_str();
  app.add_option("--starts", fit.starts,
                 "global start: candidates (the given start and Sobol points over the bounds) "
                 "each refined briefly at the nominal directions; 1: the given start only")
      ->capture_default_str();
  app.add_option("--misfit-limit", fit.misfit_limit,
                 "chi2/dof above which the fit warns that the model does not describe the data")
      ->capture_default_str();
  app.add_option("--table-u", table_u.rel,
                 "relative standard uncertainty given to tabulated input (tables carry none)")
      ->capture_default_str();
  app.add_option("--table-abs-u", table_u.abs,
                 "absolute standard uncertainty (in β) added in quadrature to the relative one "
                 "for tabulated input: the floor of tiny values")
      ->capture_default_str();
  app.add_flag("--no-naive", no_naive, "skip the comparison fit at the nominal directions");
  app.add_flag("--json", json, "JSON result");
  app.add_option("--plot", plot, "plot: measured, fitted virtual and true β, residuals "
                                 "(.png, .svg, .pdf)");
}

FitOptions FitCliOptions::options() const {
  if (samples->count() > 0 && max_samples->count() > 0)
    throw Error::invalid("samples", "give --samples alone (a fit's fixed budget; --max-samples is taken for it)");
  if (max_samples->count() > 0)
    std::cerr << "gonio-twin " << command << ": a fit spends a fixed budget, --samples; --max-samples was taken as it\n";
  auto o = fit;
  o.naive = !no_naive;
  o.validate();
  return o;
}

InstrumentProfile FitCliOptions::load_profile() const {
  auto p = InstrumentProfile::load(profile);
  if (calibration == "fixed") p.calibration.mode = CalibrationMode::fixed;
  if (calibration == "per-geometry") p.calibration.mode = CalibrationMode::per_geometry;
  return p;
}

void write_fit_table(std::ostream& out, const FitResult& r, const std::string& title) {
  out << title << '\n';
  const bool naive = !r.naive.empty();
  out << fmt::format("{:<28} {:>13} {:>11}{}\n", "parameter", "value", "u",
                     naive ? fmt::format(" {:>13}", "naive") : "");
  for (std::size_t j = 0; j < r.parameters.size(); ++j) {
    const auto& p = r.parameters[j];
    const auto u = std::isfinite(p.u) ? fmt::format("{:11.4g}", p.u) : fmt::format("{:>11}", "—");
    std::string nv;
    if (naive) nv = fmt::format(" {:13.6g}", r.naive.front().parameters[j].value);
    out << fmt::format("{:<28} {:13.6g} {}{}{}\n", p.name, p.value, u, nv,
                       p.identifiable ? "" : "  (not identifiable)");
  }
  if (r.parameters.size() > 1 && r.parameters.size() <= 8) {
    out << "correlation\n";
    for (const auto& row : r.correlation) {
      out << " ";
      for (double v : row) out << fmt::format(" {:6.3f}", v);
      out << '\n';
    }
  }
  out << fmt::format("chi2/dof {:.4g} ({} dof), {} points, {} residuals, {} iterations, {} "
                     "evaluations, {:.2f} s, {}\n",
                     r.chi2_per_dof, r.dof, r.points, r.residuals, r.iterations, r.evaluations,
                     r.seconds, r.status);
  if (naive)
    out << fmt::format("naive fit (nominal directions, no instrument): chi2/dof {:.4g}\n",
                       r.naive.front().chi2_per_dof);
  for (const auto& w : r.warnings) out << "warning: " << w << '\n';
}

std::vector<std::string> fit_notes(const FitResult& r) {
  std::vector<std::string> out;
  const auto value = [](const FittedParameter& p) {
    return std::isfinite(p.u) && !p.at_bound ? text::format_measured(p.value, p.u)
                                             : fmt::format("{:.4g}{}", p.value,
                                                           p.at_bound ? " (at bound)" : "");
  };
  // Consecutive parameters of one mark ("lambert.albedo@400", "@410", …) form a group.
  const auto mark = [](const std::string& name) { return name.substr(0, name.find('@')); };
  for (std::size_t j = 0; j < r.parameters.size();) {
    std::size_t k = j + 1;
    const auto& name = r.parameters[j].name;
    const bool per = name.find('@') != std::string::npos;
    while (per && k < r.parameters.size() && mark(r.parameters[k].name) == mark(name)) ++k;
    if (!per || k - j <= 4) {
      for (std::size_t i = j; i < k; ++i)
        out.push_back(fmt::format("{} = {}", r.parameters[i].name, value(r.parameters[i])));
    } else {
      double lo = r.parameters[j].value, hi = lo;
      int bound = 0;
      for (std::size_t i = j; i < k; ++i) {
        lo = std::min(lo, r.parameters[i].value);
        hi = std::max(hi, r.parameters[i].value);
        bound += r.parameters[i].at_bound ? 1 : 0;
      }
      out.push_back(fmt::format("{}: {} channels, {:.4g} … {:.4g}{}", mark(name), k - j, lo, hi,
                                bound > 0 ? fmt::format(" ({} at bound)", bound) : ""));
    }
    j = k;
  }
  out.push_back(fmt::format("χ²/dof = {:.4g} ({} dof)", r.chi2_per_dof, r.dof));
  if (!r.naive.empty())
    out.push_back(fmt::format("naive χ²/dof = {:.4g}", r.naive.front().chi2_per_dof));
  if (r.chi2_per_dof > 2 && !r.misfit.empty()) {
    const auto& m = r.misfit.front();
    out.push_back(fmt::format("worst: θi = {:g}°, {} ({:.0f} % of χ²)", m.theta_i, m.region,
                              100 * m.chi2_share));
  }
  return out;
}

void plot_fit(const std::string& path, const std::vector<CorrectedPoint>& points,
              const std::string& title, const FitResult& result) {
  std::map<double, std::vector<const CorrectedPoint*>> by_incidence;
  for (const auto& p : points) by_incidence[p.geometry.theta_i].push_back(&p);
  Figure fig;
  fig.title = title;
  fig.notes = fit_notes(result);
  fig.width = 1000;
  fig.height = 750;
  fig.panels.reserve(2);
  Panel& beta = fig.panels.emplace_back();
  beta.x = Axis("receiving angle θr", "°");
  bool positive = true;
  for (const auto& p : points)
    for (double v : p.measured) positive = positive && v > 0;
  beta.y = Axis("radiance factor β (channel mean)").logarithmic(positive);
  beta.height_ratio = 2;
  Panel& res = fig.panels.emplace_back();
  res.x = Axis("receiving angle θr", "°");
  res.y = Axis("(virtual − measured) / u");
  res.y_reference_lines = {0};
  res.legend = LegendPlacement::none;
  const auto mean = [](const std::vector<double>& v) { return channel_mean(v); };
  std::size_t k = 0;
  for (auto& [ti, list] : by_incidence) {
    std::sort(list.begin(), list.end(), [](const auto* a, const auto* b) {
      return a->geometry.theta_r < b->geometry.theta_r;
    });
    std::vector<double> x, m, mu, v, t, z;
    for (const auto* p : list) {
      x.push_back(p->geometry.theta_r);
      m.push_back(mean(p->measured));
      mu.push_back(mean(p->measured_u));
      v.push_back(mean(p->virtual_beta));
      t.push_back(mean(p->true_beta));
      double zz = 0;
      for (std::size_t c = 0; c < p->measured.size(); ++c) {
        const double s = std::hypot(p->measured_u[c], p->virtual_se[c]);
        zz += s > 0 ? (p->virtual_beta[c] - p->measured[c]) / s : 0;
      }
      z.push_back(zz / static_cast<double>(std::max<std::size_t>(1, p->measured.size())));
    }
    const auto color = palette_color(k++);
    // One legend entry per incidence (its colour); the line styles are explained once below.
    auto& sm = beta.series.emplace_back(fmt::format("θi = {:g}°", ti), x, m, mu);
    sm.color = color;
    sm.line = LineStyle::none;
    sm.marker = Marker::circle;
    sm.marker_size = 4;
    auto& sv = beta.series.emplace_back("", x, v);
    sv.color = color;
    if (!result.nominal_directions) {  // else virtual and true are the same curve
      auto& st = beta.series.emplace_back("", x, t);
      st.color = color;
      st.line = LineStyle::dashed;
    }
    auto& sz = res.series.emplace_back("", x, z);
    sz.color = color;
    sz.line = LineStyle::none;
    sz.marker = Marker::circle;
    sz.marker_size = 4;
  }
  // The styles' legend entries: no data drawn, a grey sample of each style.
  const auto style = [&](const std::string& label, LineStyle line, Marker marker) {
    auto& s = beta.series.emplace_back(label, std::vector<double>{0.0},
                                       std::vector<double>{std::numeric_limits<double>::quiet_NaN()});
    s.color = Rgba{0.35, 0.35, 0.35, 1};
    s.line = line;
    s.marker = marker;
    s.marker_size = 4;
  };
  style("measured ± u", LineStyle::none, Marker::circle);
  style(result.nominal_directions ? "fitted model" : "fitted, virtual", LineStyle::solid, Marker::none);
  if (!result.nominal_directions) style("fitted, true", LineStyle::dashed, Marker::none);
  write_figure(fig, path);
}

void write_corrected_csv(const std::string& path, const std::vector<CorrectedPoint>& points,
                         const WavelengthGrid& grid) {
  std::ofstream out(path);
  if (!out) throw Error(Errc::io_error, fmt::format("cannot write '{}'", path), "corrected");
  out << "theta_i,phi_i,theta_r,phi_r,wavelength_nm,measured,measured_u,virtual,virtual_se,"
         "true,corrected,corrected_u\n";
  for (const auto& p : points)
    for (std::size_t c = 0; c < grid.size(); ++c)
      out << fmt::format("{:g},{:g},{:g},{:g},{:g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},"
                         "{:.9g}\n",
                         p.geometry.theta_i, p.geometry.phi_i, p.geometry.theta_r,
                         p.geometry.phi_r, grid[c], p.measured[c], p.measured_u[c],
                         p.virtual_beta[c], p.virtual_se[c], p.true_beta[c], p.corrected[c],
                         p.corrected_u[c]);
  if (!out) throw Error(Errc::io_error, fmt::format("cannot write '{}'", path), "corrected");
}

// The corrected values as an isotropic spherical BRDF table (in_plane.hpp). The points must
// fill the grid, as for goniod's tabulated exports.
BsdfTable corrected_table(const std::vector<CorrectedPoint>& points, const WavelengthGrid& grid) {
  std::vector<InPlaneReading> readings;
  readings.reserve(points.size());
  for (const auto& p : points) readings.push_back({p.geometry, p.corrected});
  return in_plane_table(readings, grid.values(),
                        {.what = "the points",
                         .remedy = "write the corrected table as .csv",
                         .field = "corrected"});
}

void write_corrected(const std::string& path, const std::vector<CorrectedPoint>& points,
                     const WavelengthGrid& grid, const std::string& spec) {
  const auto dot = path.find_last_of('.');
  std::string ext = dot == std::string::npos ? "" : path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".csv") return write_corrected_csv(path, points, grid);
  if (ext != ".bsdf" && ext != ".ssdd")
    throw Error::invalid("corrected", fmt::format("'{}': write .csv, .bsdf (IS-SA) or .ssdd", path));
  TabulatedParts parts;
  parts.brdf = corrected_table(points, grid);
  parts.name = "instrument-corrected measurement (fitted model " + spec + ")";
  IssaWriteOptions o;
  o.weights = luminance_weights(grid.values());
  o.comment = "instrument-corrected measurement, f = beta/pi; fitted model " + spec;
  if (!o.weights.empty()) o.comment += "; Monochrome = luminance factor (D65, 10 deg)";
  write_bsdf_file(path, parts, o);
}

void add_fit(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "fit", "fit material parameters ('?' in the spec) to measured data through the twin");
  auto o = std::make_shared<FitCliOptions>();
  auto model = std::make_shared<std::string>();
  auto corrected = std::make_shared<std::string>();
  sub->add_option("--model", *model,
                  "BSDF spec with free parameters: 'conductor:alpha=?,eta=0.2,k=3.9', "
                  "alpha=?0.1[0.001,1], albedo=?* (per channel)")
      ->required();
  o->add_to(*sub);
  sub->add_option("--corrected", *corrected,
                  "write the instrument-corrected table, measured × true/virtual per point: .csv, "
                  ".bsdf (IS-SA) or .ssdd (a full in-plane grid)");
  sub->callback([o, model, corrected] {
    exit_code() = guarded([&] {
      const auto data = load_measured(o->measured, o->table_u);
      const auto profile = o->load_profile();
      const auto options = o->options();
      const auto r = [&] {
        Ticker ticker("fit");  // erased before the result is printed
        ticker.step(fmt::format("fitting {} to {} points", *model, data.points.size()));
        return fit_material(data, *model, profile, options);
      }();
      if (o->json)
        std::cout << r.to_json().dump(2) << '\n';
      else
        write_fit_table(std::cout, r,
                        r.nominal_directions
                            ? fmt::format("fit of {} to {} at the nominal directions (a table "
                                          "holds f at exact directions: no instrument)",
                                          *model, data.source)
                            : fmt::format("fit of {} to {} through the {} twin", *model,
                                          data.source, profile.name));
      if (!corrected->empty() || !o->plot.empty()) {
        auto high = options;
        high.samples = std::max<std::uint64_t>(options.samples, 1u << 16);
        Ticker ticker("fit");
        ticker.step("correcting the measured points");
        const auto points = correct(data, r.spec, profile, high);
        if (!corrected->empty()) write_corrected(*corrected, points, data.wavelengths, r.spec);
        if (!o->plot.empty()) plot_fit(o->plot, points, "fit of " + *model, r);
      }
      // What was written and how big; beside --json's document, not in it.
      auto& said = o->json ? std::cerr : std::cout;
      for (const auto* path : {corrected.get(), &o->plot})
        if (!path->empty()) said << fmt::format("wrote {} ({})\n", *path, file_size_text(*path));
      return kExitOk;
    });
  });
}

}  // namespace gonio::twin::cli
