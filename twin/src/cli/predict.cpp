// gonio-twin predict: the radiance factor the instrument would report, with its error.
#include <cmath>
#include <iostream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/common.hpp"
#include "cli/output.hpp"
#include "gonio/twin/budget.hpp"

namespace gonio::twin::cli {

void add_predict(CLI::App& app) {
  auto* sub = app.add_subcommand("predict", "predict β(λ) and its standard error per geometry");
  auto model = std::make_shared<ModelOptions>();
  auto geo = std::make_shared<GeometryOptions>();
  auto json = std::make_shared<bool>(false);
  auto csv = std::make_shared<bool>(false);
  auto budget = std::make_shared<bool>(false);
  model->add_to(*sub);
  geo->add_to(*sub);
  auto* j = sub->add_flag("--json", *json, "JSON: one object per geometry");
  auto* c = sub->add_flag("--csv", *csv, "CSV: one row per geometry and wavelength")->excludes(j);
  sub->add_flag("--budget", *budget,
                "the uncertainty budget from the profile's stated tolerances (GUM): each "
                "component's u, sensitivity and contribution (with --json: per channel)")
      ->excludes(c);
  sub->callback([model, geo, json, csv, budget] {
    exit_code() = guarded([&] {
      const auto twin = model->make_twin();
      const auto options = model->estimator_options();
      const auto predictions = twin.predict_many(geo->geometries(), options, model->threads);
      if (*budget) {
        const BudgetModel bm(twin);
        std::vector<Budget> budgets;
        for (const auto& p : predictions) budgets.push_back(bm.evaluate(p, options));
        if (*json) {
          auto out = predictions_json(predictions);
          for (std::size_t i = 0; i < budgets.size(); ++i) out[i]["budget"] = budgets[i];
          std::cout << out.dump(2) << '\n';
        } else {
          write_budget_table(std::cout, predictions, budgets);
        }
      } else if (*json) {
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
