// gonio-twin error-map: virtually measure a BSDF over a grid and compare with the truth.
//
// The truth at a geometry is β = π f(ωi, ωr) at the nominal directions — what an ideal
// instrument with infinitesimal apertures, perfect arms and an infinite sample would read.
// The virtual reading is the twin's prediction. Summary figures use the channel mean of β
// (a grey summary; the CSV has every channel):
//   relative error      (virtual − true) / true, over geometries where the truth is at least
//                       `floor` × the peak of its incidence angle (tails are not ratios);
//   peak under-estimation  per incidence angle, (max virtual − max true) / max true;
//   grazing loss        mean relative error over geometries with θi or |θr| ≥ 70°.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>

#include <fmt/format.h>
#include <fmt/ostream.h>
#include <nlohmann/json.hpp>

#include "cli/common.hpp"
#include "cli/error_map_plot.hpp"
#include "cli/output.hpp"
#include "cli/progress.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::twin::cli {
namespace {

struct ErrorMapOptions {
  std::string grid = "in=15,45,75;out=-85:85:1";
  std::string out = "error-map.csv";
  std::string plot;  // default: the CSV's name with .png
  double floor = 0.01;
  bool log = false;
  bool json = false;
};

}  // namespace

ErrorMapSummary summarise(const std::vector<ErrorMapRow>& rows, double floor) {
  ErrorMapSummary s;
  std::map<double, double> peak_true, peak_virtual;
  for (const auto& r : rows) {
    peak_true[r.geometry.theta_i] = std::max(peak_true[r.geometry.theta_i], r.true_beta);
    peak_virtual[r.geometry.theta_i] = std::max(peak_virtual[r.geometry.theta_i], r.virtual_beta);
  }
  double sum = 0, grazing_sum = 0;
  std::size_t n = 0, grazing_n = 0;
  for (const auto& r : rows) {
    if (!(r.true_beta >= floor * peak_true[r.geometry.theta_i]) || !(r.true_beta > 0)) continue;
    const double e = (r.virtual_beta - r.true_beta) / r.true_beta;
    if (std::abs(e) > std::abs(s.max_relative_error)) {
      s.max_relative_error = e;
      s.max_at = r.geometry;
    }
    sum += std::abs(e);
    ++n;
    if (r.geometry.theta_i >= 70 || std::abs(r.geometry.theta_r) >= 70) {
      grazing_sum += e;
      ++grazing_n;
    }
  }
  s.compared = n;
  s.mean_abs_relative_error = n ? sum / static_cast<double>(n) : 0;
  s.grazing_mean_relative_error =
      grazing_n ? grazing_sum / static_cast<double>(grazing_n) : std::nan("");
  for (const auto& [ti, pt] : peak_true)
    s.peak_error[ti] = pt > 0 ? (peak_virtual[ti] - pt) / pt : 0;
  return s;
}

void add_error_map(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "error-map", "virtual measurement vs true BSDF over a grid: CSV, summary and plot");
  auto model = std::make_shared<ModelOptions>();
  auto o = std::make_shared<ErrorMapOptions>();
  model->add_to(*sub);
  sub->add_option("--grid", o->grid, "geometry grid")->capture_default_str();
  sub->add_option("--output", o->out,
                  "the CSV file (a name without .csv is the old prefix: PREFIX.csv and PREFIX.png)")
      ->capture_default_str();
  sub->add_option("--plot", o->plot, "the plot (.png, .svg, .pdf; default: the CSV's name with .png)");
  sub->add_option("--floor", o->floor, "ignore true β below floor × peak in relative errors")
      ->capture_default_str();
  sub->add_flag("--log", o->log, "logarithmic β axis in the plot");
  sub->add_flag("--json", o->json, "print the summary as JSON");
  sub->callback([model, o] {
    exit_code() = guarded([&] {
      if (!(o->floor >= 0 && o->floor < 1)) throw Error::out_of_range("floor", o->floor, 0, 1);
      // --output is a file, as for the other commands; before, error-map took a prefix.
      const bool prefix = !o->out.ends_with(".csv");
      if (prefix)
        std::cerr << "gonio-twin error-map: --output is the CSV file now; '" << o->out
                  << "' is taken as the old prefix (give --output " << o->out << ".csv)\n";
      const auto csv_path = prefix ? o->out + ".csv" : o->out;
      const auto png_path =
          !o->plot.empty() ? o->plot : csv_path.substr(0, csv_path.size() - 4) + ".png";
      const auto twin = model->make_twin();
      const auto geometries = parse_geometry_grid(o->grid);
      Ticker ticker("error-map");
      ticker.step(fmt::format("measuring {} geometries", geometries.size()));
      const auto pred = twin.predict_many(geometries, model->estimator_options(), model->threads);
      std::vector<ErrorMapRow> rows;
      for (const auto& p : pred) {
        const auto t = twin.true_beta(p.geometry);
        // Channels share paths: the mean error bounds the error of the channel mean.
        rows.push_back({p.geometry, channel_mean(t), channel_mean(p.beta), channel_mean(p.std_error)});
      }
      // CSV with every channel.
      std::ofstream csv(csv_path);
      if (!csv) throw Error(Errc::io_error, fmt::format("cannot write '{}'", csv_path), "output");
      csv << "theta_i,phi_i,theta_r,phi_r,wavelength_nm,true_beta,virtual_beta,std_error,"
             "relative_error\n";
      for (const auto& p : pred) {
        const auto t = twin.true_beta(p.geometry);
        for (std::size_t c = 0; c < t.size(); ++c)
          fmt::print(csv, "{},{},{},{},{},{:.9g},{:.9g},{:.3g},{}\n", p.geometry.theta_i,
                     p.geometry.phi_i, p.geometry.theta_r, p.geometry.phi_r, p.wavelengths[c],
                     t[c], p.beta[c], p.std_error[c],
                     t[c] > 0 ? fmt::format("{:.6g}", (p.beta[c] - t[c]) / t[c]) : "");
      }
      csv.close();
      if (!csv) throw Error(Errc::io_error, fmt::format("cannot write '{}'", csv_path), "output");
      ticker.step("writing " + png_path);
      plot_error_map(png_path, rows, twin.sample().spec(), o->log);

      const auto s = summarise(rows, o->floor);
      if (o->json) {
        nlohmann::json peaks = nlohmann::json::object();
        for (const auto& [ti, e] : s.peak_error) peaks[fmt::format("{}", ti)] = e;
        std::cout << nlohmann::json{{"compared", s.compared},
                                    {"max_relative_error", s.max_relative_error},
                                    {"max_at", s.max_at},
                                    {"mean_abs_relative_error", s.mean_abs_relative_error},
                                    {"peak_error", peaks},
                                    {"grazing_mean_relative_error",
                                     std::isnan(s.grazing_mean_relative_error)
                                         ? nlohmann::json(nullptr)
                                         : nlohmann::json(s.grazing_mean_relative_error)},
                                    {"csv", csv_path},
                                    {"plot", png_path}}
                         .dump(2)
                  << '\n';
      } else {
        fmt::print("error map of {} over {} geometries ({} compared)\n", twin.sample().spec(),
                   rows.size(), s.compared);
        fmt::print("  max relative error   {:+.2f}% at {}\n", 100 * s.max_relative_error,
                   s.max_at.to_string());
        fmt::print("  mean |rel. error|    {:.2f}%\n", 100 * s.mean_abs_relative_error);
        for (const auto& [ti, e] : s.peak_error)
          fmt::print("  peak at θi = {:>4}°   {:+.2f}% (virtual vs true maximum)\n", ti, 100 * e);
        if (!std::isnan(s.grazing_mean_relative_error))
          fmt::print("  grazing (≥ 70°)      {:+.2f}% mean relative error\n",
                     100 * s.grazing_mean_relative_error);
        fmt::print("wrote {} ({}) and {} ({})\n", csv_path, file_size_text(csv_path), png_path,
                   file_size_text(png_path));
      }
      return kExitOk;
    });
  });
}

}  // namespace gonio::twin::cli
