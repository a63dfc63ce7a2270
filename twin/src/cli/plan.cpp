// gonio-twin plan: the smallest in-plane grid per incidence angle whose linear
// interpolation stays within a target error of a dense virtual measurement.
//
// The dense curve is the twin's prediction (what the instrument would read, apertures and
// all) every `dense-step` degrees. A candidate grid is a subset of the dense nodes that
// keeps both ends; it is acceptable when, at every dense node, the linear interpolation of
// the grid differs from the dense value by at most tolerance × max(β, floor × peak) — the
// floor keeps near-zero tails from demanding points for meaningless relative errors. Among
// acceptable grids we take one with the fewest points: a shortest path over the graph of
// admissible segments (exact, O(n³) worst case over the n dense nodes). Refinement lands
// near peaks and coarsening on flat stretches by construction. Only receiving angles the
// arms can reach count (ArmReach: the profile's clearance, on the arms' side of the
// collision zone), so that the grid can be pasted into a scan as it is.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/common.hpp"
#include "cli/output.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"
#include "gonio/twin/design.hpp"

namespace gonio::twin::cli {
namespace {

struct PlanOptions {
  std::string in = "45";
  std::string range = "-85:85";
  double dense_step = 0.5;
  double tolerance = 0.01;
  double floor = 0.01;
  bool json = false;
};

struct Plan {
  double theta_i = 0;
  std::vector<double> out;      // chosen receiving angles
  std::size_t dense_points = 0;
  double max_error = 0;         // achieved, relative (same measure as the tolerance)
  std::size_t unreachable = 0;  // dense angles of the range the arms cannot reach
};

// Indices of the fewest dense nodes whose interpolation meets the tolerance.
std::vector<std::size_t> minimal_nodes(const std::vector<double>& x, const std::vector<double>& y,
                                       double tol, double floor_abs) {
  const std::size_t n = x.size();
  const auto ok = [&](std::size_t i, std::size_t j) {
    for (std::size_t k = i + 1; k < j; ++k) {
      const double t = (x[k] - x[i]) / (x[j] - x[i]);
      const double interp = y[i] + t * (y[j] - y[i]);
      if (std::abs(interp - y[k]) > tol * std::max(std::abs(y[k]), floor_abs)) return false;
    }
    return true;
  };
  std::vector<std::size_t> dist(n, std::numeric_limits<std::size_t>::max()), prev(n, 0);
  dist[0] = 1;
  for (std::size_t j = 1; j < n; ++j)
    for (std::size_t i = 0; i < j; ++i)
      if (dist[i] + 1 < dist[j] && ok(i, j)) {
        dist[j] = dist[i] + 1;
        prev[j] = i;
      }
  std::vector<std::size_t> nodes{n - 1};
  while (nodes.back() != 0) nodes.push_back(prev[nodes.back()]);
  std::reverse(nodes.begin(), nodes.end());
  return nodes;
}

Plan plan_one(const Twin& twin, const EstimatorOptions& est, unsigned threads, double theta_i,
              double lo, double hi, const PlanOptions& o) {
  const ArmReach reach(twin.profile());
  std::vector<Geometry> dense;
  std::size_t unreachable = 0;
  for (double t = lo; t <= hi + 1e-9; t += o.dense_step) {
    const double r = std::round(t * 1e6) / 1e6;
    if (std::abs(std::abs(r) - 90) < 0.1) continue;
    const auto g = Geometry::in_plane(theta_i, r);
    if (!reach.reaches(g)) {
      ++unreachable;
      continue;
    }
    // One side of the zone holds one stretch of the range: no gap to interpolate across.
    if (!dense.empty() && unreachable > 0 && dense.back().theta_r < r - o.dense_step - 1e-9)
      throw Error::invalid("range", fmt::format("θi = {:g}°: the arms can reach two separate "
                                                "stretches of {}:{}; plan each on its own",
                                                theta_i, lo, hi));
    dense.push_back(g);
  }
  if (dense.size() < 2)
    throw Error::invalid("range", fmt::format("θi = {:g}°: needs at least two dense points the arms "
                                              "can reach (minimum separation {:g}°)",
                                              theta_i, reach.clearance.min_separation_deg()));
  const auto pred = twin.predict_many(dense, est, threads);
  std::vector<double> x, y;
  for (const auto& p : pred) {
    x.push_back(p.geometry.theta_r);
    y.push_back(channel_mean(p.beta));
  }
  const double peak = *std::max_element(y.begin(), y.end());
  const double floor_abs = o.floor * peak;
  const auto nodes = minimal_nodes(x, y, o.tolerance, floor_abs);
  Plan plan{theta_i, {}, dense.size(), 0, unreachable};
  for (std::size_t s = 0; s + 1 < nodes.size(); ++s)
    for (std::size_t k = nodes[s]; k <= nodes[s + 1]; ++k) {
      const std::size_t i = nodes[s], j = nodes[s + 1];
      const double t = j == i ? 0 : (x[k] - x[i]) / (x[j] - x[i]);
      const double e = std::abs(y[i] + t * (y[j] - y[i]) - y[k]) / std::max(std::abs(y[k]), floor_abs);
      plan.max_error = std::max(plan.max_error, e);
    }
  for (auto k : nodes) plan.out.push_back(x[k]);
  return plan;
}

}  // namespace

void add_plan(CLI::App& app) {
  auto* sub = app.add_subcommand(
      "plan", "smallest in-plane grid per incidence angle within a target error");
  auto model = std::make_shared<ModelOptions>();
  auto o = std::make_shared<PlanOptions>();
  model->add_to(*sub);
  sub->add_option("--in", o->in, "incidence angles, e.g. 15,45,75")->capture_default_str();
  sub->add_option("--range", o->range, "receiving-angle range LO:HI, degrees")->capture_default_str();
  sub->add_option("--dense-step", o->dense_step, "step of the dense reference curve, degrees")
      ->capture_default_str();
  auto* curve_error = sub->add_option("--curve-error", o->tolerance, "largest relative interpolation error")
                          ->capture_default_str();
  // The old name: --tolerance is a sample's acceptance limit everywhere else (gonioctl).
  auto* old_name = sub->add_option("--tolerance", o->tolerance)->group("");
  sub->add_option("--floor", o->floor,
                  "errors are relative to max(β, floor × peak): tails below it count absolutely")
      ->capture_default_str();
  sub->add_flag("--json", o->json, "JSON output");
  sub->callback([model, o, old_name, curve_error] {
    exit_code() = guarded([&] {
      if (old_name->count() > 0 && curve_error->count() > 0)
        throw Error::invalid("tolerance", "give --curve-error alone (--tolerance is its old name)");
      if (old_name->count() > 0) std::cerr << "gonio-twin plan: --tolerance is now --curve-error\n";
      if (!(o->dense_step >= 0.05 && o->dense_step <= 10))
        throw Error::out_of_range("dense-step", o->dense_step, 0.05, 10, "°");
      if (!(o->tolerance >= 3 * model->rel_se && o->tolerance <= 1))
        throw Error::out_of_range("curve-error", o->tolerance, 3 * model->rel_se, 1);
      if (!(o->floor >= 0 && o->floor <= 1)) throw Error::out_of_range("floor", o->floor, 0, 1);
      const auto parts = text::split(o->range, ':');
      if (parts.size() != 2) throw Error::invalid("range", "expected LO:HI, e.g. -85:85");
      const double lo = text::parse_double("range", parts[0]);
      const double hi = text::parse_double("range", parts[1]);
      if (!(lo >= -180 && hi <= 180 && lo < hi))
        throw Error::invalid("range", fmt::format("{}: need -180 <= LO < HI <= 180", o->range));
      const auto twin = model->make_twin();
      const auto est = model->estimator_options();
      auto json = nlohmann::json::array();
      for (double ti : text::parse_value_list("in", o->in)) {
        const auto plan = plan_one(twin, est, model->threads, ti, lo, hi, *o);
        const auto grid = fmt::format("in={};out={}", text::format_number(ti),
                                      text::format_value_list(plan.out));
        if (o->json) {
          json.push_back({{"theta_i", ti}, {"grid", grid}, {"points", plan.out.size()},
                          {"dense_points", plan.dense_points}, {"max_error", plan.max_error},
                          {"unreachable_points", plan.unreachable}});
        } else {
          std::cout << grid << '\n';
          std::cerr << fmt::format("# θi = {}°: {} points instead of {} dense, max error {:.2f}%{}\n",
                                   ti, plan.out.size(), plan.dense_points, 100 * plan.max_error,
                                   plan.unreachable == 0 ? ""
                                   : fmt::format("; θr {} {}° left out (the arms cannot reach it)",
                                                 plan.out.front() > lo + 1e-9 ? "below" : "above",
                                                 text::format_number(plan.out.front() > lo + 1e-9
                                                                         ? plan.out.front()
                                                                         : plan.out.back())));
        }
      }
      if (o->json) std::cout << json.dump(2) << '\n';
      return kExitOk;
    });
  });
}

}  // namespace gonio::twin::cli
