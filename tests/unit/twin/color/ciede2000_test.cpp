// CIEDE2000 against the published test data of G. Sharma, W. Wu, E. N. Dalal, "The CIEDE2000
// color-difference formula: implementation notes, supplementary test data, and mathematical
// observations", Color Res. Appl. 30(1), 2005, Table 1 (34 pairs, ΔE00 to 4 decimals).
#include <cmath>

#include <gtest/gtest.h>

#include "gonio/twin/color.hpp"

namespace gonio::twin {
namespace {

struct Pair {
  Lab lab1, lab2;
  double de00;
};

// Published data, transcribed: pair number = index + 1.
constexpr Pair kSharma2005[] = {
    {{50.0000, 2.6772, -79.7751}, {50.0000, 0.0000, -82.7485}, 2.0425},
    {{50.0000, 3.1571, -77.2803}, {50.0000, 0.0000, -82.7485}, 2.8615},
    {{50.0000, 2.8361, -74.0200}, {50.0000, 0.0000, -82.7485}, 3.4412},
    {{50.0000, -1.3802, -84.2814}, {50.0000, 0.0000, -82.7485}, 1.0000},
    {{50.0000, -1.1848, -84.8006}, {50.0000, 0.0000, -82.7485}, 1.0000},
    {{50.0000, -0.9009, -85.5211}, {50.0000, 0.0000, -82.7485}, 1.0000},
    {{50.0000, 0.0000, 0.0000}, {50.0000, -1.0000, 2.0000}, 2.3669},
    {{50.0000, -1.0000, 2.0000}, {50.0000, 0.0000, 0.0000}, 2.3669},
    {{50.0000, 2.4900, -0.0010}, {50.0000, -2.4900, 0.0009}, 7.1792},
    {{50.0000, 2.4900, -0.0010}, {50.0000, -2.4900, 0.0010}, 7.1792},
    {{50.0000, 2.4900, -0.0010}, {50.0000, -2.4900, 0.0011}, 7.2195},
    {{50.0000, 2.4900, -0.0010}, {50.0000, -2.4900, 0.0012}, 7.2195},
    {{50.0000, -0.0010, 2.4900}, {50.0000, 0.0009, -2.4900}, 4.8045},
    {{50.0000, -0.0010, 2.4900}, {50.0000, 0.0010, -2.4900}, 4.8045},
    {{50.0000, -0.0010, 2.4900}, {50.0000, 0.0011, -2.4900}, 4.7461},
    {{50.0000, 2.5000, 0.0000}, {50.0000, 0.0000, -2.5000}, 4.3065},
    {{50.0000, 2.5000, 0.0000}, {73.0000, 25.0000, -18.0000}, 27.1492},
    {{50.0000, 2.5000, 0.0000}, {61.0000, -5.0000, 29.0000}, 22.8977},
    {{50.0000, 2.5000, 0.0000}, {56.0000, -27.0000, -3.0000}, 31.9030},
    {{50.0000, 2.5000, 0.0000}, {58.0000, 24.0000, 15.0000}, 19.4535},
    {{50.0000, 2.5000, 0.0000}, {50.0000, 3.1736, 0.5854}, 1.0000},
    {{50.0000, 2.5000, 0.0000}, {50.0000, 3.2972, 0.0000}, 1.0000},
    {{50.0000, 2.5000, 0.0000}, {50.0000, 1.8634, 0.5757}, 1.0000},
    {{50.0000, 2.5000, 0.0000}, {50.0000, 3.2592, 0.3350}, 1.0000},
    {{60.2574, -34.0099, 36.2677}, {60.4626, -34.1751, 39.4387}, 1.2644},
    {{63.0109, -31.0961, -5.8663}, {62.8187, -29.7946, -4.0864}, 1.2630},
    {{61.2901, 3.7196, -5.3901}, {61.4292, 2.2480, -4.9620}, 1.8731},
    {{35.0831, -44.1164, 3.7933}, {35.0232, -40.0716, 1.5901}, 1.8645},
    {{22.7233, 20.0904, -46.6940}, {23.0331, 14.9730, -42.5619}, 2.0373},
    {{36.4612, 47.8580, 18.3852}, {36.2715, 50.5065, 21.2231}, 1.4146},
    {{90.8027, -2.0831, 1.4410}, {91.1528, -1.6435, 0.0447}, 1.4441},
    {{90.9257, -0.5406, -0.9208}, {88.6381, -0.8985, -0.7239}, 1.5381},
    {{6.7747, -0.2908, -2.4247}, {5.8714, -0.0985, -2.2286}, 0.6377},
    {{2.0776, 0.0795, -1.1350}, {0.9033, -0.0636, -0.5514}, 0.9082},
};

TEST(Ciede2000, MatchesSharmaWuDalal2005TestData) {
  static_assert(std::size(kSharma2005) == 34);
  int n = 0;
  for (const auto& p : kSharma2005) {
    ++n;
    // The published values are rounded to 4 decimals.
    EXPECT_NEAR(delta_e2000(p.lab1, p.lab2), p.de00, 0.5e-4) << "pair " << n;
    EXPECT_NEAR(delta_e2000(p.lab2, p.lab1), p.de00, 0.5e-4) << "pair " << n << " swapped";
  }
}

// The signed terms a least-squares fit uses: their squares sum to ΔE00² on the published
// pairs (the rotation term included: pairs 1–6 are blue, where RT is largest), and the
// lightness term carries the sign of ΔL.
TEST(Ciede2000, SignedTermsSquareToTheDifference) {
  int n = 0;
  for (const auto& p : kSharma2005) {
    ++n;
    const auto t = delta_e2000_terms(p.lab1, p.lab2);
    EXPECT_NEAR(std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]), delta_e2000(p.lab1, p.lab2), 1e-12)
        << "pair " << n;
  }
  EXPECT_LT(delta_e2000_terms(Lab{51, 0, 0}, Lab{49, 0, 0})[0], 0);
  EXPECT_GT(delta_e2000_terms(Lab{49, 0, 0}, Lab{51, 0, 0})[0], 0);
}

TEST(Ciede2000, IsZeroForEqualColorsAndGrowsWithDistance) {
  const Lab c{42, 13, -7};
  EXPECT_EQ(delta_e2000(c, c), 0.0);
  const double near = delta_e2000(c, Lab{43, 13, -7});
  const double far = delta_e2000(c, Lab{48, 13, -7});
  EXPECT_GT(near, 0);
  EXPECT_GT(far, near);
}

TEST(Ciede2000, ParametricFactorsScaleTheirTerm) {
  // A pure lightness difference at L̄ = 50 (S_L = 1): ΔE00 = ΔL / kL.
  const Lab a{49, 0, 0}, b{51, 0, 0};
  EXPECT_NEAR(delta_e2000(a, b), 2.0, 1e-12);
  EXPECT_NEAR(delta_e2000(a, b, 2.0), 1.0, 1e-12);
}

}  // namespace
}  // namespace gonio::twin
