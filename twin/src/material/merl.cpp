// MERL .binary out: the model sampled at the nodes the twin's MERL reader puts the
// database's samples at (tabulated/merl.cpp: θh = 90°·(k/90)², θd = 90°·k/90, φd = 180°·k/180,
// Rusinkiewicz's half-difference angles as tab::half_difference defines them), so that
// reading the file back gives the model's values at those nodes exactly (up to rounding in
// the channel scale). Channels are the model at the three wavelengths the reader assigns to
// B, G, R (kRgbWavelengthsNm). A node whose directions lie below the horizon (θd large at
// large θh) holds the value just above it, so that interpolation toward grazing angles does
// not pull values toward zero.
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <ostream>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf_io.hpp"
#include "gonio/twin/material.hpp"

namespace gonio::twin::material {
namespace {

constexpr int kThetaH = 90, kThetaD = 90, kPhiD = 180;
constexpr double kAboveHorizon = 1e-3;
// A stored value times its channel's scale (R, G, B) is f in sr⁻¹: the database's reader and
// the twin's (tabulated/merl.cpp); the round-trip test holds the two together.
constexpr std::array<double, 3> kMerlScale{1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};  // cos θ of a direction pulled up to the horizon

Vec3 above_horizon(Vec3 w) {
  if (w.z >= kAboveHorizon) return w;
  const double r = std::sqrt(w.x * w.x + w.y * w.y);
  const double s = std::sqrt(1 - kAboveHorizon * kAboveHorizon) / (r > 0 ? r : 1);
  return {r > 0 ? w.x * s : s, r > 0 ? w.y * s : 0, kAboveHorizon};
}

// (wi, wo) of half-difference angles (radians) with φh = 0: wi is d rotated by θh about y,
// wo its mirror image about the half vector (the inverse of tab::half_difference).
std::pair<Vec3, Vec3> directions(double theta_h, double theta_d, double phi_d) {
  const Vec3 d{std::sin(theta_d) * std::cos(phi_d), std::sin(theta_d) * std::sin(phi_d), std::cos(theta_d)};
  const double ch = std::cos(theta_h), sh = std::sin(theta_h);
  const Vec3 wi{ch * d.x + sh * d.z, d.y, -sh * d.x + ch * d.z};
  const Vec3 h{sh, 0, ch};
  const Vec3 wo = 2 * dot(wi, h) * h - wi;
  return {wi, wo};
}

void put_le(std::ostream& out, std::uint64_t v, int bytes) {
  char b[8];
  for (int k = 0; k < bytes; ++k) b[k] = static_cast<char>((v >> (8 * k)) & 0xff);
  out.write(b, bytes);
}

}  // namespace

void write_merl(std::ostream& out, const Bsdf& model) {
  const auto& nm = model.wavelengths().values();
  if (nm.size() != 3 || nm[0] != kRgbWavelengthsNm[0] || nm[1] != kRgbWavelengthsNm[1] ||
      nm[2] != kRgbWavelengthsNm[2])
    throw Error::invalid("wavelengths", "a MERL table is written from a model on the three RGB "
                                        "wavelengths 464.3, 549.1, 611.5 nm");
  const std::size_t n = static_cast<std::size_t>(kThetaH) * kThetaD * kPhiD;
  std::vector<double> rgb(3 * n);
  std::array<double, 3> f{};
  for (int ih = 0; ih < kThetaH; ++ih) {
    const double x = static_cast<double>(ih) / kThetaH;
    const double th = 90.0 * x * x * kDegToRad;
    for (int id = 0; id < kThetaD; ++id) {
      const double td = 90.0 * id / kThetaD * kDegToRad;
      for (int ip = 0; ip < kPhiD; ++ip) {
        const double pd = 180.0 * ip / kPhiD * kDegToRad;
        const auto [wi, wo] = directions(th, td, pd);
        model.eval(above_horizon(wi), above_horizon(wo), f);
        const std::size_t at = (static_cast<std::size_t>(ih) * kThetaD + static_cast<std::size_t>(id)) * kPhiD +
                               static_cast<std::size_t>(ip);
        for (std::size_t c = 0; c < 3; ++c) rgb[c * n + at] = f[2 - c] / kMerlScale[c];  // R, G, B
      }
    }
  }
  for (const int d : {kThetaH, kThetaD, kPhiD}) put_le(out, static_cast<std::uint32_t>(d), 4);
  for (const double v : rgb) put_le(out, std::bit_cast<std::uint64_t>(v), 8);
  if (!out) throw Error(Errc::io_error, "cannot write the MERL table", "output");
}

void write_merl(const std::string& path, const Bsdf& model) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw Error(Errc::io_error, fmt::format("cannot open '{}' for writing", path), "output");
  write_merl(out, model);
  out.close();
  if (!out) throw Error(Errc::io_error, fmt::format("cannot write '{}'", path), "output");
}

RoundTrip merl_round_trip(const Bsdf& model, const Bsdf& table, double max_theta_r) {
  constexpr double kFloor = 0.01 * kInvPi;  // β = 0.01: below it, differences are absolute
  RoundTrip r;
  std::array<double, 3> a{}, b{};
  double sum = 0;
  std::size_t count = 0;
  const int last = static_cast<int>(max_theta_r);
  for (int ti = 0; ti <= std::min(80, last); ti += 5) {
    const double t = ti * kDegToRad;
    const Vec3 wi{-std::sin(t), 0, std::cos(t)};
    for (int tr = -last; tr <= last; ++tr) {
      const double u = tr * kDegToRad;
      const Vec3 wo{std::sin(u), 0, std::cos(u)};
      model.eval(wi, wo, a);
      table.eval(wi, wo, b);
      for (std::size_t c = 0; c < 3; ++c) {
        const double e = std::abs(b[c] - a[c]) / std::max(a[c], kFloor);
        sum += e;
        ++count;
        if (e > r.max_rel) r = {e, r.mean_rel, static_cast<double>(ti), static_cast<double>(tr)};
      }
    }
  }
  r.mean_rel = sum / static_cast<double>(count);
  return r;
}

}  // namespace gonio::twin::material
