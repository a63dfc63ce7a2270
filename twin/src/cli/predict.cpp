// gonio-twin predict: the radiance factor the instrument would report, with its error.
#include <cmath>
#include <iostream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/common.hpp"
#include "cli/output.hpp"

namespace gonio::twin::cli {

void add_predict(CLI::App& app) {
  auto* sub = app.add_subcommand("predict", "predict β(λ) and its standard error per geometry");
  auto model = std::make_shared<ModelOptions>();
  auto geo = std::make_shared<GeometryOptions>();
  auto json = std::make_shared<bool>(false);
  auto csv = std::make_shared<bool>(false);
  model->add_to(*sub);
  geo->add_to(*sub);
  auto* j = sub->add_flag("--json", *json, "JSON: one object per geometry");
  sub->add_flag("--csv", *csv, "CSV: one row per geometry and wavelength")->excludes(j);
  sub->callback([model, geo, json, csv] {
    exit_code() = guarded([&] {
      const auto twin = model->make_twin();
      const auto predictions =
          twin.predict_many(geo->geometries(), model->estimator_options(), model->threads);
      if (*json) {
        std::cout << predictions_json(predictions).dump(2) << '\n';
      } else if (*csv) {
        write_predictions_csv(std::cout, predictions);
      } else {
        write_predictions_table(std::cout, predictions);
      }
      return kExitOk;
    });
  });
}

}  // namespace gonio::twin::cli
