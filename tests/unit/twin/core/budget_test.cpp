// The twin's uncertainty budget against a direct Monte Carlo propagation of the stated
// tolerances (GUM Supplement 1, JCGM 101:2008: draw the inputs from their distributions, run
// the model, take the spread), and the tolerances' parsing.
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf.hpp"
#include "gonio/twin/budget.hpp"

namespace gonio::twin {
namespace {

const WavelengthGrid kGrid = WavelengthGrid::parse("450,550,650");

EstimatorOptions fixed_budget() {
  EstimatorOptions o;
  o.rel_se = 1e-6;
  o.abs_se = 0;
  o.max_samples = 1u << 15;
  o.replicates = 16;
  return o;
}

double stddev(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m += x;
  m /= static_cast<double>(v.size());
  double ss = 0;
  for (double x : v) ss += (x - m) * (x - m);
  return std::sqrt(ss / static_cast<double>(v.size() - 1));
}

// The arms' contributions against β at arm offsets drawn uniformly within ±0.5°: at a glossy
// peak (where the first derivative vanishes and only the second-order term is left), on its
// flank, and on a matte sample.
class ArmsAgainstMonteCarlo : public ::testing::TestWithParam<std::tuple<std::string, double>> {};

TEST_P(ArmsAgainstMonteCarlo, CombinedArmContributionMatchesTheSpreadOfDrawnOffsets) {
  const auto [spec, theta_r] = GetParam();
  const Twin twin(InstrumentProfile{}, make_bsdf(spec, kGrid), kGrid);
  const auto g = Geometry::in_plane(45, theta_r);
  const auto options = fixed_budget();
  const auto nominal = twin.predict(g, options);
  const BudgetModel model(twin);
  const auto budget = model.evaluate(nominal, options);
  ASSERT_EQ(budget.components.size(), 7u);
  const std::size_t k = 1;  // 550 nm
  const double predicted = std::hypot(budget.components[0].contribution[k], budget.components[1].contribution[k]);

  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> arm(-0.5, 0.5);
  std::vector<double> beta;
  const auto mc = BudgetModel::variant_options(options, nominal.samples);
  for (int i = 0; i < 96; ++i) {
    auto p = twin.profile();
    p.arms.incidence_offset_deg = arm(rng);
    p.arms.receive_offset_deg = arm(rng);
    beta.push_back(twin.with_profile(p).predict(g, mc).beta[k]);
  }
  const double observed = stddev(beta);
  if (observed < 1e-9 * nominal.beta[k]) {
    // A Lambertian sample read against the white at each geometry: the arms cancel out.
    EXPECT_LT(predicted, 1e-9 * nominal.beta[k]) << spec << " at " << g.to_string();
    return;
  }
  // 96 draws give the spread to about ±8 % (1σ); the quadratic model of the budget is exact
  // only for a quadratic β, so allow ±35 %.
  EXPECT_GT(predicted, 0.65 * observed) << spec << " at " << g.to_string();
  EXPECT_LT(predicted, 1.35 * observed) << spec << " at " << g.to_string();
}

std::string case_name(const ::testing::TestParamInfo<std::tuple<std::string, double>>& param) {
  static const char* const kCases[] = {"GlossyPeak", "GlossyFlank", "Matte"};
  return kCases[param.index];
}

INSTANTIATE_TEST_SUITE_P(Budget, ArmsAgainstMonteCarlo,
                         ::testing::Values(std::make_tuple(std::string("conductor:alpha=0.05,eta=0.2,k=3.9"), 45.0),
                                           std::make_tuple(std::string("conductor:alpha=0.05,eta=0.2,k=3.9"), 40.0),
                                           std::make_tuple(std::string("lambert:albedo=0.5"), 0.0)),
                         case_name);

TEST(Budget, ProportionalComponentsAreTheirRelativeUncertaintyOfBeta) {
  const Twin twin(InstrumentProfile{}, make_bsdf("lambert:albedo=0.5", kGrid), kGrid);
  const auto options = fixed_budget();
  const auto nominal = twin.predict(Geometry::in_plane(45, 0), options);
  const auto b = BudgetModel(twin).evaluate(nominal, options);
  const auto& white = b.components[5];
  ASSERT_EQ(white.name, "reference_white_rel");
  EXPECT_FALSE(white.random);
  // Spectral certificate: 0.5 % at 400 nm, 0.3 % from 500 nm, linear between.
  EXPECT_NEAR(white.u[0], 0.004, 1e-12);
  EXPECT_NEAR(white.u[1], 0.003, 1e-12);
  EXPECT_NEAR(white.contribution[0], 0.004 * nominal.beta[0], 1e-12);
  const auto& lamp = b.components[6];
  EXPECT_TRUE(lamp.random);
  EXPECT_NEAR(lamp.contribution[2], 0.001 * nominal.beta[2], 1e-12);
  for (std::size_t k = 0; k < kGrid.size(); ++k) {
    double ss = 0;
    for (const auto& c : b.components) ss += c.contribution[k] * c.contribution[k];
    EXPECT_NEAR(b.u_model[k], std::sqrt(ss), 1e-12);
    EXPECT_GE(b.u_model[k], b.u_random[k]);
  }
  // A matte sample hardly cares where the arms point: the white dominates.
  EXPECT_LT(b.components[1].contribution[1], white.contribution[1]);
}

TEST(Budget, CostsAtMostThreePlainPredictions) {
  const Twin twin(InstrumentProfile{}, make_bsdf("conductor:alpha=0.05,eta=0.2,k=3.9", kGrid), kGrid);
  EstimatorOptions options;
  options.rel_se = 2e-3;
  const auto nominal = twin.predict(Geometry::in_plane(45, 40), options);
  const auto b = BudgetModel(twin).evaluate(nominal, options);
  // Counted in paths, not seconds: 8 variants at a quarter of the nominal's paths each, so
  // a prediction with its budget costs at most 3 plain ones.
  EXPECT_LE(b.samples, 2 * nominal.samples + 8 * 1024);
}

TEST(Tolerances, ParsedStrictlyAndRoundTrip) {
  const auto j = nlohmann::json::parse(R"({"tolerances": {
      "receive_arm_deg": {"distribution": "rectangular", "half_width": 0.2},
      "reference_white_rel": {"distribution": "normal", "u": [[400, 0.01], [700, 0.002]]},
      "lamp_stability_rel": {"distribution": "triangular", "half_width": 0.004}}})");
  const auto p = j.get<InstrumentProfile>();
  EXPECT_DOUBLE_EQ(p.receive_arm_tolerance().half_width, 0.2);
  EXPECT_DOUBLE_EQ(p.incidence_arm_tolerance().half_width, 0.5);  // the arms' accuracy
  EXPECT_NEAR(p.tolerances.reference_white_rel.standard_uncertainty(550), 0.006, 1e-12);
  EXPECT_NEAR(p.tolerances.lamp_stability_rel.standard_uncertainty(), 0.004 / std::sqrt(6.0), 1e-12);
  const nlohmann::json back = p;
  EXPECT_EQ(back.get<InstrumentProfile>(), p);
}

TEST(Tolerances, AToleranceWithoutItsDistributionIsRefusedByName) {
  const auto fails = [](const char* text) -> std::string {
    try {
      nlohmann::json::parse(text).get<InstrumentProfile>();
    } catch (const Error& e) {
      return e.field();
    }
    return "accepted";
  };
  EXPECT_EQ(fails(R"({"tolerances": {"receive_arm_deg": {"half_width": 0.2}}})"),
            "profile.tolerances.receive_arm_deg.distribution");
  EXPECT_EQ(fails(R"({"tolerances": {"receive_arm_deg": {"distribution": "uniform", "half_width": 0.2}}})"),
            "profile.tolerances.receive_arm_deg.distribution");
  EXPECT_EQ(fails(R"({"tolerances": {"lamp_stability_rel": {"distribution": "normal", "half_width": 0.2}}})"),
            "profile.tolerances.lamp_stability_rel.half_width");
  EXPECT_EQ(fails(R"({"tolerances": {"source_aperture_rel": {"distribution": "rectangular", "half_width": 2}}})"),
            "profile.tolerances.source_aperture_rel.half_width");
  EXPECT_EQ(fails(R"({"tolerances": {"lamp_stability_rel": {"distribution": "normal", "u": [[500, 0.1]]}}})"),
            "profile.tolerances.lamp_stability_rel.u");
  EXPECT_EQ(fails(R"({"tolerances": {"arms_deg": {"distribution": "normal", "u": 1}}})"),
            "profile.tolerances.arms_deg");
}

}  // namespace
}  // namespace gonio::twin
