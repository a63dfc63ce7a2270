// Auto-ranging decisions: shorter while saturated down to the minimum, longer while
// under-exposed up to the maximum and below any setting that saturated.
#include <gtest/gtest.h>

#include "gonio/daemon/instrument/autorange.hpp"

namespace gonio::daemon {
namespace {

drivers::Reading reading(std::vector<double> v, std::vector<double> u) {
  drivers::Reading r;
  const WavelengthGrid grid({500.0, 600.0});
  r.spectrum = Spectrum(grid, std::move(v), std::move(u));
  return r;
}

TEST(Autorange, SaturationShortensByTheStepDownToTheMinimumThenGivesUp) {
  const RangeLimits lim{1, 2000, 10};
  EXPECT_DOUBLE_EQ(*next_integration_ms(100, true, 0, std::nullopt, lim), 25);
  EXPECT_DOUBLE_EQ(*next_integration_ms(2, true, 0, std::nullopt, lim), 1);
  EXPECT_FALSE(next_integration_ms(1, true, 0, std::nullopt, lim));
}

TEST(Autorange, UnderExposureLengthensUpToTheMaximumAndBelowASaturatedSetting) {
  const RangeLimits lim{1, 1000, 10};
  EXPECT_DOUBLE_EQ(*next_integration_ms(100, false, 3, std::nullopt, lim), 400);
  EXPECT_DOUBLE_EQ(*next_integration_ms(400, false, 3, std::nullopt, lim), 1000);
  EXPECT_FALSE(next_integration_ms(1000, false, 3, std::nullopt, lim));
  EXPECT_FALSE(next_integration_ms(100, false, 10, std::nullopt, lim));  // well exposed
  // 25 ms is under-exposed but 100 ms saturated at this point: keep 25 ms.
  EXPECT_FALSE(next_integration_ms(25, false, 3, 100.0, lim));
}

TEST(Autorange, TheBestChannelsSignalToNoiseDecides) {
  const auto dark = reading({100, 100}, {3, 4});
  EXPECT_NEAR(best_channel_snr(reading({103, 130}, {4, 0}), dark), 30.0 / 4, 1e-12);
  EXPECT_DOUBLE_EQ(best_channel_snr(reading({90, 95}, {4, 3}), dark), 0);
}

}  // namespace
}  // namespace gonio::daemon
