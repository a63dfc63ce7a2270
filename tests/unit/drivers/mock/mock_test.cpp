// The mock instrument: readings follow the twin, runs repeat for a seed, the two sides
// share one lab, and every scripted fault arrives as its typed error.
#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/sim/mock/mock.hpp"
#include "gonio/registry/registry.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/twin/twin.hpp"

using gonio::Errc;
using gonio::Error;
using nlohmann::json;
using namespace gonio::drivers;
using namespace std::chrono_literals;

namespace {

json base_config() {
  return json{{"sample", "lambert:albedo=0.4"},
              {"wavelengths", "450,550,650"},
              {"seed", 7},
              {"estimator", {{"rel_se", 0.01}, {"max_samples", 8192}, {"replicates", 4}}}};
}

Errc code_of(auto&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.code();
  }
  return Errc::internal;
}

std::vector<double> beta(Photometer& p) {
  const auto d = p.measure(Channel::dark, 1s);
  const auto r = p.measure(Channel::reference, 1s);
  const auto s = p.measure(Channel::sample, 1s);
  std::vector<double> b;
  for (std::size_t i = 0; i < s.spectrum.size(); ++i)
    b.push_back((s.spectrum.values[i] - d.spectrum.values[i]) / (r.spectrum.values[i] - d.spectrum.values[i]));
  return b;
}

}  // namespace

TEST(MockInstrument, ReadingsFollowTheTwin) {
  auto m = mock::make_mock(base_config());
  m.motion->move(Axis::incidence, 45, 1s);
  m.motion->move(Axis::receive, 0, 1s);
  const auto b = beta(*m.photometer);
  ASSERT_EQ(b.size(), 3u);
  // A Lambertian sample of albedo 0.4 reads β ≈ 0.4 against a white of β = 1; noise at
  // ~2e4 counts is well under 2 %.
  for (const double v : b) EXPECT_NEAR(v, 0.4, 0.03);
}

TEST(MockInstrument, PhotometerSeesWhereTheArmsAre) {
  auto cfg = base_config();
  cfg["sample"] = "conductor:alpha=0.1,eta=0.2,k=3.9";
  cfg["gain_counts_per_ms"] = 20;  // keep the specular peak below full scale
  auto m = mock::make_mock(cfg);
  m.motion->move(Axis::incidence, 30, 1s);
  m.motion->move(Axis::receive, 30, 1s);  // specular
  const double peak = beta(*m.photometer)[1];
  m.motion->move(Axis::receive, -10, 1s);  // far off the lobe
  const double off = beta(*m.photometer)[1];
  EXPECT_GT(peak, 5 * off);
}

TEST(MockInstrument, DeterministicForASeed) {
  auto a = mock::make_mock(base_config());
  auto b = mock::make_mock(base_config());
  const auto ra = a.photometer->measure(Channel::sample, 1s);
  const auto rb = b.photometer->measure(Channel::sample, 1s);
  EXPECT_EQ(ra.spectrum, rb.spectrum);
  auto cfg = base_config();
  cfg["seed"] = 8;
  auto c = mock::make_mock(cfg);
  EXPECT_NE(c.photometer->measure(Channel::sample, 1s).spectrum.values, ra.spectrum.values);
}

TEST(MockInstrument, LampDriftShowsBetweenReferenceReadings) {
  auto cfg = base_config();
  cfg["lamp_drift_per_s"] = 0.01;
  cfg["read_noise_counts"] = 0;
  cfg["gain_counts_per_ms"] = 1e6;  // shot noise negligible against the drift
  cfg["full_scale_counts"] = 1e15;
  auto m = mock::make_mock(cfg);
  const double r1 = m.photometer->measure(Channel::reference, 1s).spectrum.values[0];
  for (int i = 0; i < 10; ++i) m.photometer->measure(Channel::dark, 1s);
  const double r2 = m.photometer->measure(Channel::reference, 1s).spectrum.values[0];
  EXPECT_GT(r2 / r1, 1.005);  // ~1.1 virtual s later: +1.1 %
}

TEST(MockInstrument, PositionRepeatabilityMovesTheLightNotTheEncoder) {
  // On the steep flank of a glossy lobe, β changes by tens of percent per degree: landing
  // errors of up to ±0.5° spread repeated readings far beyond the detector's noise, while
  // the arm still reads back at its target.
  const auto spread = [](double repeatability) {
    auto cfg = base_config();
    cfg["sample"] = "conductor:alpha=0.05,eta=0.2,k=3.9";
    cfg["read_noise_counts"] = 0;
    cfg["gain_counts_per_ms"] = 1e5;
    cfg["full_scale_counts"] = 1e15;
    cfg["position_repeatability_deg"] = repeatability;
    auto m = mock::make_mock(cfg);
    m.motion->move(Axis::incidence, 45, 1s);
    double lo = 1e300, hi = 0;
    for (int i = 0; i < 12; ++i) {
      m.motion->move(Axis::receive, 20, 1s);
      m.motion->move(Axis::receive, 52, 1s);
      EXPECT_DOUBLE_EQ(m.motion->position(Axis::receive, 1s), 52);
      const double b = beta(*m.photometer)[1];
      lo = std::min(lo, b);
      hi = std::max(hi, b);
    }
    return (hi - lo) / lo;
  };
  const double still = spread(0), loose = spread(0.5);
  EXPECT_LT(still, 0.05);
  EXPECT_GT(loose, 3 * still);
  EXPECT_GT(loose, 0.1);
}

TEST(MockInstrument, PositionRepeatabilityIsRangeChecked) {
  auto cfg = base_config();
  cfg["position_repeatability_deg"] = 9;
  try {
    mock::make_mock(cfg);
    FAIL() << "accepted 9°";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "mock.position_repeatability_deg");
  }
}

TEST(MockInstrument, ScriptedFaultsAreTypedErrors) {
  const auto with = [](const char* fault, int n) {
    auto cfg = base_config();
    cfg["faults"] = {{fault, n}, {"timeout_wait_ms", 10}};
    return mock::make_mock(cfg);
  };
  {
    auto m = with("disconnect_at_point", 2);
    m.photometer->measure(Channel::sample, 1s);
    EXPECT_EQ(code_of([&] { m.photometer->measure(Channel::sample, 1s); }), Errc::disconnected);
    EXPECT_EQ(code_of([&] { m.photometer->measure(Channel::reference, 1s); }), Errc::disconnected);
    EXPECT_NO_THROW(m.motion->move(Axis::incidence, 10, 1s));  // only the photometer is unplugged
    // A replug: a new handle on the same lab works, the old one stays dead, and the point
    // count goes on (the fault does not fire again).
    auto again = mock::connect_photometer(m.lab);
    EXPECT_NO_THROW(again->measure(Channel::sample, 1s));
    EXPECT_EQ(code_of([&] { m.photometer->measure(Channel::dark, 1s); }), Errc::disconnected);
  }
  {
    auto cfg = base_config();
    cfg["faults"] = {{"disconnect_at_point", 1}, {"reconnect_after_ms", 3600000}};
    auto m = mock::make_mock(cfg);
    EXPECT_EQ(code_of([&] { m.photometer->measure(Channel::sample, 1s); }), Errc::disconnected);
    EXPECT_EQ(code_of([&] { mock::connect_photometer(m.lab); }), Errc::disconnected);  // still out
  }
  {
    auto m = with("timeout_at_point", 1);
    EXPECT_EQ(code_of([&] { m.photometer->measure(Channel::sample, 1s); }), Errc::timeout);
    EXPECT_NO_THROW(m.photometer->measure(Channel::sample, 1s));  // one-off
  }
  {
    auto m = with("garbage_at_point", 1);
    EXPECT_EQ(code_of([&] { m.photometer->measure(Channel::sample, 1s); }), Errc::protocol_error);
  }
  {
    auto m = with("saturate_at_point", 1);
    EXPECT_EQ(code_of([&] { m.photometer->measure(Channel::sample, 1s); }), Errc::saturated);
    auto m2 = with("saturate_at_point", 1);
    const auto r = m2.photometer->measure(Channel::sample, 1s, SaturationPolicy::flag);
    EXPECT_TRUE(r.saturated);
  }
  {
    auto m = with("stall_at_move", 2);
    m.motion->move(Axis::incidence, 20, 1s);
    EXPECT_EQ(code_of([&] { m.motion->move(Axis::incidence, 40, 1s); }), Errc::device_alarm);
    EXPECT_DOUBLE_EQ(m.motion->position(Axis::incidence, 1s), 30);  // half way
    const auto st = m.motion->status(Axis::incidence, 1s);
    EXPECT_TRUE(st.alarm);
    EXPECT_EQ(st.alarm_code, 0x10u);
    m.motion->reset_alarm(Axis::incidence, 1s);
    EXPECT_FALSE(m.motion->status(Axis::incidence, 1s).alarm);
  }
}

TEST(MockInstrument, ConfigIsStrict) {
  auto cfg = base_config();
  cfg["colour"] = "red";
  EXPECT_EQ(code_of([&] { mock::make_mock(cfg); }), Errc::invalid_argument);
  cfg = base_config();
  cfg["faults"] = {{"explode_at_point", 1}};
  EXPECT_EQ(code_of([&] { mock::make_mock(cfg); }), Errc::invalid_argument);
  cfg = base_config();
  cfg["lamp_drift_per_s"] = 5;
  try {
    mock::make_mock(cfg);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::out_of_range);
    EXPECT_EQ(e.field(), "mock.lamp_drift_per_s");
  }
}

TEST(MockInstrument, RegistryBuildsASharedLab) {
  json motion = base_config();
  motion["driver"] = "mock";
  auto inst = open_instrument(json{{"motion", motion}, {"photometer", {{"driver", "mock"}}}});
  ASSERT_TRUE(inst.motion && inst.photometer);
  EXPECT_EQ(inst.photometer->identify(1s).model, "MOCK");
  EXPECT_TRUE(find_driver("mock").photometer);
  EXPECT_TRUE(find_driver("scpi-usbtmc").photometer);
  EXPECT_FALSE(find_driver("scpi-tcp").motion);
  EXPECT_EQ(code_of([] { find_driver("nope"); }), Errc::not_found);
  EXPECT_EQ(code_of([] { make_motion("scpi-tcp", json::object()); }), Errc::unsupported);
  // Unknown keys are rejected before any connection is tried.
  EXPECT_EQ(code_of([] { make_photometer("scpi-tcp", json{{"host", "127.0.0.1"}, {"baud", 9600}}); }),
            Errc::invalid_argument);
}

// The lab's detector model follows the integration time: the signal grows with it, the
// shot noise with its square root, and full scale is reached at a longer setting.
TEST(MockInstrument, SignalAndNoiseFollowTheIntegrationTime) {
  auto cfg = base_config();
  cfg["full_scale_counts"] = 60000;  // the white reads 400 counts/ms: saturates above 150 ms
  auto m = mock::make_mock(cfg);
  const auto net = [&](double ms) {
    m.photometer->set_integration_ms(ms, 1s);
    const auto d = m.photometer->measure(Channel::dark, 1s);
    const auto r = m.photometer->measure(Channel::reference, 1s, SaturationPolicy::flag);
    EXPECT_DOUBLE_EQ(r.integration_ms, ms);
    return std::pair{r.spectrum.values[1] - d.spectrum.values[1], r.spectrum.std_uncertainty[1]};
  };
  const auto [s25, u25] = net(25);
  const auto [s100, u100] = net(100);
  EXPECT_NEAR(s100 / s25, 4.0, 0.1);
  EXPECT_NEAR(u100 / u25, 2.0, 0.1);  // √(signal): shot noise dominates the read noise here
  m.photometer->set_integration_ms(200, 1s);
  EXPECT_TRUE(m.photometer->measure(Channel::reference, 1s, SaturationPolicy::flag).saturated);
  EXPECT_EQ(code_of([&] { m.photometer->measure(Channel::reference, 1s); }), Errc::saturated);
}
