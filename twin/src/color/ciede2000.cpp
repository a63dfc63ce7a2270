// CIEDE2000 colour difference.
//
// CIE 142-2001 as written out step by step in G. Sharma, W. Wu, E. N. Dalal, "The CIEDE2000
// color-difference formula: implementation notes, supplementary test data, and mathematical
// observations", Color Res. Appl. 30(1), 2005, eq. (1)–(22). The notes' pitfalls are
// followed: hue angles in [0°, 360°), h' = 0 for a neutral colour, Δh' and the mean hue
// h̄' taken around the shorter arc, and the mean hue of a pair with a neutral member being
// the plain sum h'1 + h'2 (eq. 14).
#include <algorithm>
#include <cmath>

#include "gonio/twin/color.hpp"
#include "gonio/twin/vec.hpp"

namespace gonio::twin {
namespace {

double hue_deg(double b, double a) {
  if (a == 0 && b == 0) return 0;
  const double h = std::atan2(b, a) * kRadToDeg;
  return h < 0 ? h + 360 : h;
}

double cosd(double deg) { return std::cos(deg * kDegToRad); }
double sind(double deg) { return std::sin(deg * kDegToRad); }
double pow7(double x) { return x * x * x * x * x * x * x; }

}  // namespace

namespace {

// tl, tc, th and RT of eq. (22): ΔE00² = tl² + tc² + th² + RT tc th.
struct Terms {
  double tl, tc, th, rt;
};

Terms terms(const Lab& lab1, const Lab& lab2, double kl, double kc, double kh) {
  const double pow25_7 = pow7(25.0);
  // eq. (2)–(7): a' stretched by G, then C' and h'
  const double c1 = std::hypot(lab1.a, lab1.b);
  const double c2 = std::hypot(lab2.a, lab2.b);
  const double c_mean7 = pow7(0.5 * (c1 + c2));
  const double g = 0.5 * (1 - std::sqrt(c_mean7 / (c_mean7 + pow25_7)));
  const double a1 = (1 + g) * lab1.a;
  const double a2 = (1 + g) * lab2.a;
  const double cp1 = std::hypot(a1, lab1.b);
  const double cp2 = std::hypot(a2, lab2.b);
  const double h1 = hue_deg(lab1.b, a1);
  const double h2 = hue_deg(lab2.b, a2);
  const bool neutral = cp1 * cp2 == 0;

  // eq. (8)–(11): differences
  const double dl = lab2.l - lab1.l;
  const double dc = cp2 - cp1;
  double dh = 0;
  if (!neutral) {
    dh = h2 - h1;
    if (dh > 180) dh -= 360;
    else if (dh < -180) dh += 360;
  }
  const double d_big_h = 2 * std::sqrt(cp1 * cp2) * sind(0.5 * dh);

  // eq. (12)–(22): weighting functions and the rotation term
  const double l_mean = 0.5 * (lab1.l + lab2.l);
  const double c_mean = 0.5 * (cp1 + cp2);
  double h_mean = h1 + h2;
  if (!neutral) {
    if (std::abs(h1 - h2) <= 180) h_mean = 0.5 * (h1 + h2);
    else if (h1 + h2 < 360) h_mean = 0.5 * (h1 + h2 + 360);
    else h_mean = 0.5 * (h1 + h2 - 360);
  }
  const double t = 1 - 0.17 * cosd(h_mean - 30) + 0.24 * cosd(2 * h_mean) +
                   0.32 * cosd(3 * h_mean + 6) - 0.20 * cosd(4 * h_mean - 63);
  const double d_theta = 30 * std::exp(-std::pow((h_mean - 275) / 25, 2));
  const double cm7 = pow7(c_mean);
  const double rc = 2 * std::sqrt(cm7 / (cm7 + pow25_7));
  const double l50 = (l_mean - 50) * (l_mean - 50);
  const double sl = 1 + 0.015 * l50 / std::sqrt(20 + l50);
  const double sc = 1 + 0.045 * c_mean;
  const double sh = 1 + 0.015 * c_mean * t;
  const double rt = -sind(2 * d_theta) * rc;

  return {dl / (kl * sl), dc / (kc * sc), d_big_h / (kh * sh), rt};
}

}  // namespace

double delta_e2000(const Lab& lab1, const Lab& lab2, double kl, double kc, double kh) {
  const auto [tl, tc, th, rt] = terms(lab1, lab2, kl, kc, kh);
  return std::sqrt(std::max(0.0, tl * tl + tc * tc + th * th + rt * tc * th));
}

std::array<double, 3> delta_e2000_terms(const Lab& lab1, const Lab& lab2) {
  // tc² + th² + RT tc th = (tc + RT/2 th)² + (1 − RT²/4) th², |RT| ≤ 2 (RC ≤ 2).
  const auto [tl, tc, th, rt] = terms(lab1, lab2, 1, 1, 1);
  return {tl, tc + 0.5 * rt * th, th * std::sqrt(std::max(0.0, 1 - 0.25 * rt * rt))};
}

}  // namespace gonio::twin
