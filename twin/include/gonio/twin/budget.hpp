// The twin's uncertainty budget: what the instrument's stated tolerances do to a predicted β
// (GUM, JCGM 100:2008 §5; the second-order term of its §5.1.2 note, for the distribution at
// hand, where the model is not linear).
//
// Each input x of the instrument (an arm's angle, an aperture, the white standard's
// certificate, the lamp) has a stated tolerance (InstrumentProfile::tolerances) and so a
// standard uncertainty u(x). The twin finds the sensitivity of β to it by finite differences
// with common random numbers (the same seed and sample count for every variant, so the
// difference is smooth and not Monte Carlo noise), each at a step of the tolerance itself:
//
//   arms       central differences at ±h (h = the half-width, or √3·u for a normal input):
//              c1 = (β₊ − β₋)/2h, c2 = (β₊ − 2β₀ + β₋)/h², so a glossy peak, where the first
//              derivative vanishes, still gets its second-order term
//              u_x(β)² = c1²u² + ¼c2²(κ − 1)u⁴   (κ = E[x⁴]/u⁴: 9/5 rectangular, 3 normal)
//   apertures  forward differences at +h (first order)
//   white, lamp  β is proportional to them: c = β, no twin run
//
// The variants run at a quarter of the nominal prediction's paths (at least 1,024), so the
// budget costs 7/4 of a plain prediction on top of it. Components marked `random` vary from
// point to point (arm repeatability, the lamp between the white's reading and the sample's);
// the others are the same for a whole scan, which is why a scan can fit them
// (docs/architecture.md §6).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "gonio/twin/instrument.hpp"
#include "gonio/twin/twin.hpp"

namespace gonio::twin {

struct BudgetComponent {
  std::string name;                   // the tolerance's key: "receive_arm_deg", ...
  std::string unit;                   // of the input: "deg", or "1" for a relative one
  Distribution distribution = Distribution::rectangular;
  bool random = false;                // independent from point to point
  std::vector<double> u;              // standard uncertainty of the input, per channel
  std::vector<double> sensitivity;    // ∂β/∂x per channel
  std::vector<double> curvature;      // ∂²β/∂x² per channel (0: taken as linear)
  // ∂²β/∂x∂y with the input `cross_with` (the receive arm's row carries the arms'
  // interaction, which moves a glossy peak's shoulders by a percent or two at ±0.4° each).
  std::string cross_with;
  std::vector<double> cross;
  std::vector<double> contribution;   // standard uncertainty of β it causes, per channel
};

struct Budget {
  std::vector<BudgetComponent> components;
  std::vector<double> u_model;         // all contributions in quadrature, per channel
  std::vector<double> u_random;        // those of the random components alone
  std::vector<double> beta_base;       // the nominal β at the variants' budget (their base)
  std::uint64_t samples = 0;           // paths traced for the budget
  double seconds = 0;
};

// {"components": [{component, distribution, unit, random, u, sensitivity, contribution}],
//  "u_model": [...]}; `u` is a number when it is the same for every channel.
void to_json(nlohmann::json& j, const BudgetComponent& c);
void to_json(nlohmann::json& j, const Budget& b);

class BudgetModel {
 public:
  // The variant twins of `twin`, sharing its BSDFs.
  explicit BudgetModel(const Twin& twin);

  const Twin& nominal() const noexcept { return variants_.front(); }

  // The budget at nominal.geometry, for `nominal` predicted with `options` (its seed is
  // used for every variant). Thread-safe.
  Budget evaluate(const Prediction& nominal, const EstimatorOptions& options) const;

  // The options of the variants for a nominal prediction that traced `samples` paths.
  static EstimatorOptions variant_options(const EstimatorOptions& options, std::uint64_t samples);

 private:
  const InstrumentProfile& nominal_profile() const noexcept { return variants_.front().profile(); }

  std::vector<Twin> variants_;  // nominal, incidence ±, receive ±, source +, receiver +, both arms +
  Tolerance incidence_, receive_;
};

}  // namespace gonio::twin
