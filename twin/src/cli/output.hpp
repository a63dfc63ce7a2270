// Text, CSV and JSON renderings of predictions, shared by the subcommands.
#pragma once

#include <ostream>
#include <vector>

#include <nlohmann/json.hpp>

#include "gonio/twin/budget.hpp"
#include "gonio/twin/twin.hpp"

namespace gonio::twin::cli {

int& exit_code();

nlohmann::json prediction_json(const Prediction& p);
nlohmann::json predictions_json(const std::vector<Prediction>& ps);
void write_predictions_csv(std::ostream& out, const std::vector<Prediction>& ps);
void write_predictions_table(std::ostream& out, const std::vector<Prediction>& ps);
// Per geometry, the GUM table: each input quantity with its distribution, standard
// uncertainty, sensitivity coefficient and contribution (at the channel of largest β), then the
// twin's own s.e., u_model, the combined u_c and U = 2·u_c.
void write_budget_table(std::ostream& out, const std::vector<Prediction>& ps,
                        const std::vector<Budget>& budgets);
// Channel mean of a spectrum-valued quantity (the summary number of tables and plans).
double channel_mean(const std::vector<double>& v);

}  // namespace gonio::twin::cli
