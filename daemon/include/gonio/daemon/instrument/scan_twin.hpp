// ScanTwin — everything the twin predicts for one point of a scan (docs/architecture.md §6):
// the prediction, its uncertainty budget from the instrument's stated tolerances, and the
// sensitivity of β to each numeric parameter of the sample's catalogued BSDF (what the
// scan's verdict fits when the sample itself may have changed).
//
// The sample's parameters are found in its spec: a scalar `key=value` is one parameter
// ("conductor.alpha"), a spectrum given as nm:value nodes is one parameter per node
// ("lambert.albedo@600", the band around that node). Each is varied by 5 % of its value
// (inward when that would leave the model's range), with the budget's common random numbers.
//
// A catalogue with its own uncertainty (a master reference, a fitted model, a stated
// model_u) adds the budget's "catalogue" entry at every point (catalogue.hpp).
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "gonio/proto/point.hpp"
#include "gonio/twin/budget.hpp"
#include "gonio/twin/twin.hpp"

namespace gonio::daemon {

// A numeric parameter of a BSDF spec: where its value stands in the spec's text.
struct SpecParameter {
  std::string name;        // "lobe.key" or "lobe.key@nm"
  double value = 0;
  std::size_t offset = 0;  // of the value's text in the spec
  std::size_t length = 0;
  // The spec with this parameter set to `v`.
  std::string with(const std::string& spec, double v) const;
};

// Every numeric parameter of `spec`, in order (at most `limit`).
std::vector<SpecParameter> spec_parameters(const std::string& spec, std::size_t limit = 8);

class ScanTwin {
 public:
  struct Candidate {
    SpecParameter parameter;
    double step = 0;  // the value's change in the variant
    std::shared_ptr<const twin::Twin> twin;
  };
  struct PointPrediction {
    twin::Prediction prediction;
    twin::Budget budget;
    std::vector<SampleSensitivity> sample;
  };

  // The catalogue's relative u per channel at a geometry (empty: none).
  using CatalogueU = std::function<std::vector<double>(const Geometry&)>;

  // `make` builds a twin of a spec with the nominal's profile and grid; a parameter whose
  // variant it refuses on both sides is left out.
  ScanTwin(std::shared_ptr<const twin::Twin> nominal, const std::string& spec,
           const std::function<std::shared_ptr<const twin::Twin>(const std::string&)>& make,
           CatalogueU catalogue_u = {});

  const twin::Twin& nominal() const noexcept { return *nominal_; }
  const std::vector<Candidate>& candidates() const noexcept { return candidates_; }

  // Thread-safe.
  PointPrediction predict(const Geometry& g, const twin::EstimatorOptions& options) const;

 private:
  std::shared_ptr<const twin::Twin> nominal_;
  twin::BudgetModel budget_;
  std::vector<Candidate> candidates_;
  CatalogueU catalogue_u_;
};

// The point record's budget lines (4 significant digits: they are uncertainties).
std::vector<BudgetEntry> budget_entries(const twin::Budget& b);

}  // namespace gonio::daemon
