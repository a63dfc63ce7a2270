// One chi-square case of a sampler against its own pdf (stats.hpp's chi2_test) with the
// binning that resolves its lobe: the whole sphere, or an axis map around the mirrored or
// the refracted direction, optionally on one side of the surface only. Shared by the
// per-model test (models_test.cpp) and the tests of sums (sampling_test.cpp).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <ostream>
#include <string>

#include "stats.hpp"

namespace gonio::twin::test {

enum class Binning { sphere, specular, refracted };
// Where draws are binned: everywhere, or only on the receiver's side (reflection) or the
// other side (transmission), so that each binning resolves the one peak it holds.
enum class Side { all, reflection, transmission };

struct Chi2Case {
  std::string spec;
  double theta_o;  // degrees from +z; > 90 is below the surface
  Binning binning = Binning::sphere;
  double scale = 0;       // angular scale of the axis binning, radians
  bool lossless = false;  // the pdf integrates to 1
  Side side = Side::all;
};

inline std::ostream& operator<<(std::ostream& os, const Chi2Case& c) {
  static const char* const sides[] = {"", " (reflection side)", " (transmission side)"};
  return os << c.spec << " @ " << c.theta_o << " deg" << sides[static_cast<int>(c.side)];
}

// Refraction of the macro-surface for the axis of transmission lobes.
inline Vec3 refracted(const Vec3& wo, double ior) {
  const bool below = wo.z < 0;
  const double e = below ? 1 / ior : ior;
  const Vec3 n{0, 0, below ? -1.0 : 1.0};
  const double c = std::abs(wo.z);
  const double s2 = (1 - c * c) / (e * e);
  const double ct = std::sqrt(std::max(0.0, 1 - s2));
  return normalize(-wo / e + (c / e - ct) * n);
}

// 60000 draws at wo = (θo, 30°); the seed depends on θo only, so a case gives the same
// draws wherever it is listed. With about 80 cases in all, a 1e-4 significance level keeps
// the family-wise false alarm rate under 1 % (Šidák), and the seeds are fixed.
inline void expect_sampling_matches_pdf(const Chi2Case& c) {
  SCOPED_TRACE(::testing::PrintToString(c));
  const auto grid = WavelengthGrid::parse("450,550,650");
  const auto b = make_bsdf(c.spec, grid);
  const Vec3 wo = dir_deg(c.theta_o, 30);
  SphereMap map = cos_phi_map();
  if (c.binning == Binning::specular) map = axis_map(reflect(wo, {0, 0, 1}), c.scale);
  if (c.binning == Binning::refracted) {
    const auto pos = c.spec.find("ior=");
    map = axis_map(refracted(wo, std::stod(c.spec.substr(pos + 4))), c.scale);
  }
  if (c.side != Side::all) {
    const bool same = c.side == Side::reflection;
    map = restricted(map, [wo, same](const Vec3& w) { return (w.z * wo.z > 0) == same; });
  }
  const int n = 60000;
  const auto r = chi2_test(*b, wo, map, n, 0x5eed + static_cast<std::uint64_t>(c.theta_o));
  EXPECT_GT(r.p_value, 1e-4) << "chi2 = " << r.statistic << " with " << r.dof << " dof; worst "
                             << r.worst;
  EXPECT_LT(r.max_pdf_mismatch, 1e-6);
  EXPECT_LE(r.pdf_integral, 1.0 + 2e-3);
  EXPECT_GT(r.success_fraction, 0.0);
  if (c.lossless) {
    EXPECT_NEAR(r.pdf_integral, 1.0, 2e-3);
  }
}

}  // namespace gonio::twin::test
