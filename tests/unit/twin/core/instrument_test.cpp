#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/twin/instrument.hpp"

namespace gonio::twin {
namespace {

TEST(InstrumentProfile, Gcms4PresetCarriesThePaperNumbers) {
  const auto p = InstrumentProfile::preset("gcms4");
  EXPECT_EQ(p.source.aperture_deg, (Extent{2.1, 4.2}));
  EXPECT_EQ(p.receiver.aperture_deg, (Extent{1.6, 1.4}));
  EXPECT_EQ(p.receiver.field_mm, (Extent{8, 16}));
  EXPECT_EQ(p.receiver.slit_mm, (Extent{2.8, 2.4}));
  EXPECT_DOUBLE_EQ(p.arms.accuracy_deg, 0.5);
  EXPECT_EQ(p.calibration.mode, CalibrationMode::per_geometry);
  EXPECT_EQ(p.reference_bsdf, "lambert:albedo=1");
  EXPECT_NO_THROW(p.validate());
  EXPECT_THROW(InstrumentProfile::preset("gcms5"), Error);
}

TEST(InstrumentProfile, JsonRoundTripAndPartialOverrides) {
  InstrumentProfile p;
  p.arms.receive_offset_deg = 0.3;
  p.calibration.mode = CalibrationMode::fixed;
  p.source.beam_shape = ApertureShape::ellipse;
  const nlohmann::json j = p;
  EXPECT_EQ(j.get<InstrumentProfile>(), p);
  const auto q = nlohmann::json::parse(R"({"sample_mm":[50,60],"arms":{"incidence_offset_deg":-0.2}})")
                     .get<InstrumentProfile>();
  EXPECT_EQ(q.sample_mm, (Extent{50, 60}));
  EXPECT_DOUBLE_EQ(q.arms.incidence_offset_deg, -0.2);
  EXPECT_EQ(q.receiver, InstrumentProfile{}.receiver);
}

TEST(InstrumentProfile, RejectsUnknownKeysAndOutOfRangeValues) {
  try {
    nlohmann::json::parse(R"({"source":{"apperture_deg":[1,2]}})").get<InstrumentProfile>();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "profile.source.apperture_deg");
  }
  try {
    nlohmann::json::parse(R"({"receiver":{"aperture_deg":[1.6,-1]}})").get<InstrumentProfile>();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::out_of_range);
    EXPECT_EQ(e.field(), "profile.receiver.aperture_deg[1]");
  }
  EXPECT_THROW(nlohmann::json::parse(R"({"calibration":{"mode":"sometimes"}})").get<InstrumentProfile>(),
               Error);
  EXPECT_THROW(InstrumentProfile::load("no/such/profile.json"), Error);
}

}  // namespace
}  // namespace gonio::twin
