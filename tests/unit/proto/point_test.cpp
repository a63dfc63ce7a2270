// A measured point as stored and sent (proto/include/gonio/proto/point.hpp).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/point.hpp"
#include "gonio/test/error_of.hpp"

namespace gonio {
namespace {

using nlohmann::json;

TEST(PointRecord, RoundTripsWithAndWithoutPrediction) {
  PointRecord p;
  p.scan_id = 3;
  p.index = 17;
  p.geometry_index = 8;
  p.repeat = 1;
  p.planned = Geometry::in_plane(45, -30);
  p.actual = Geometry::in_plane(45.01, -29.98);
  p.started_at = "2024-01-01T00:00:00.000Z";
  p.finished_at = "2024-01-01T00:00:01.000Z";
  p.measured = Spectrum(WavelengthGrid::parse("400,500"), {0.5, 0.6}, {0.01, 0.02});
  p.flags = {"reference_read"};
  EXPECT_EQ(json(p).get<PointRecord>(), p);
  p.predicted = Spectrum(WavelengthGrid::parse("400,500"), {0.52, 0.61}, {0.003, 0.004});
  p.twin_version = "t";
  p.z_max = 1.5;
  p.delta_e00 = 0.7;
  p.diverged = true;
  EXPECT_EQ(json(p).get<PointRecord>(), p);
  auto j = json(p);
  j["extra"] = 1;
  EXPECT_EQ(test::error_of([&] { (void)j.get<PointRecord>(); }).field(), "extra");
}

}  // namespace
}  // namespace gonio
