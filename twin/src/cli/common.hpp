// Options shared by the gonio-twin subcommands and the helpers that turn them into a Twin.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "gonio/proto/geometry.hpp"
#include "gonio/twin/twin.hpp"

namespace gonio::twin::cli {

// Exit codes of gonio-twin (documented in the README).
inline constexpr int kExitOk = 0;
inline constexpr int kExitUsage = 2;    // bad option or value
inline constexpr int kExitInput = 3;    // unreadable or malformed input file
inline constexpr int kExitOutput = 4;   // output could not be written
inline constexpr int kExitInternal = 70;

struct ModelOptions {
  std::string profile = "gcms4";
  std::string bsdf;
  std::string wavelengths = "400:700:10";
  std::string estimator = "rqmc";
  // The twin's defaults, goniod's too (estimator_options.hpp); render asks for less.
  double rel_se = EstimatorOptions{}.rel_se;
  std::uint64_t max_samples = EstimatorOptions{}.max_samples;
  int replicates = EstimatorOptions{}.replicates;
  std::uint64_t seed = 1;
  unsigned threads = 0;
  // Calibration overrides of the profile.
  std::string calibration;

  void add_to(CLI::App& app, bool need_bsdf = true);
  EstimatorOptions estimator_options() const;
  InstrumentProfile load_profile() const;
  WavelengthGrid grid() const;
  Twin make_twin() const;
};

struct GeometryOptions {
  double in = 45, out = 0, az_in = 0, az_out = 0;
  std::string grid;
  std::vector<std::string> named;  // e.g. 45as15

  void add_to(CLI::App& app);
  std::vector<Geometry> geometries() const;
};

// Runs `body`, mapping gonio::Error and std::exception to a message on stderr and an exit code.
int guarded(const std::function<int()>& body);

void add_predict(CLI::App& app);
void add_error_map(CLI::App& app);
void add_plan(CLI::App& app);
void add_design(CLI::App& app);
void add_render(CLI::App& app);
void add_convert(CLI::App& app);
void add_fit(CLI::App& app);
void add_calibrate(CLI::App& app);
void add_material(CLI::App& app);

}  // namespace gonio::twin::cli
