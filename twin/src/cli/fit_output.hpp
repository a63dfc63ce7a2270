// What `gonio-twin fit` and `gonio-twin calibrate` share: the budget options of the inverse
// twin, the human table of a fit result, the instrument-corrected table and the plot.
#pragma once

#include <ostream>
#include <string>

#include <CLI/CLI.hpp>

#include "gonio/twin/fit.hpp"

namespace gonio::twin::cli {

struct FitCliOptions {
  std::string measured;
  std::string profile = "gcms4";
  std::string calibration;
  TableUncertainty table_u;
  FitOptions fit;
  bool no_naive = false;
  bool json = false;
  std::string plot;
  std::string command;  // fit or calibrate
  CLI::Option* samples = nullptr;
  CLI::Option* max_samples = nullptr;  // the common options' spelling, taken for --samples

  void add_to(CLI::App& app);
  FitOptions options() const;  // says on stderr when --max-samples stood for --samples
  InstrumentProfile load_profile() const;
};

void write_fit_table(std::ostream& out, const FitResult& r, const std::string& title);
// Measured ± u, the fitted virtual measurement, the fitted true β and the normalised
// residuals, per incidence angle over θr (channel means).
// The result's parameters, model and χ²/dof are listed beside the panels (a mark free per
// channel as its range over the channels, so that any number of channels fits).
void plot_fit(const std::string& path, const std::vector<CorrectedPoint>& points,
              const std::string& title, const FitResult& result);
// Those lines.
std::vector<std::string> fit_notes(const FitResult& r);
// CSV: one row per point and wavelength (geometry, measured, virtual, true, corrected).
void write_corrected_csv(const std::string& path, const std::vector<CorrectedPoint>& points,
                         const WavelengthGrid& grid);

}  // namespace gonio::twin::cli
