// MERL binary: tiny files generated here (the reader accepts any resolution with the
// database's mapping), the database's own 90 × 90 × 180 layout, and malformed files.
#include <bit>
#include <cstdint>
#include <sstream>

#include <gtest/gtest.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf_io.hpp"
#include "tab_testing.hpp"

namespace gonio::twin {
namespace {

using tabtest::error_of;

void put_i32(std::string& s, std::int32_t v) {
  const auto u = std::bit_cast<std::uint32_t>(v);
  for (int k = 0; k < 4; ++k) s.push_back(static_cast<char>((u >> (8 * k)) & 0xff));
}
void put_f64(std::string& s, double v) {
  const auto u = std::bit_cast<std::uint64_t>(v);
  for (int k = 0; k < 8; ++k) s.push_back(static_cast<char>((u >> (8 * k)) & 0xff));
}

// Stored value for (θh index, θd index, φd index, channel 0 = R … 2 = B); the test decodes it.
double stored(int ih, int id, int ip, int c) { return 1500.0 * (1 + ih + 0.01 * id + 0.0001 * ip) * (c + 1); }

// A MERL file of the given resolution, φd fastest, then θd, then θh, blocks R, G, B.
std::string merl_file(int nh, int nd, int np) {
  std::string s;
  put_i32(s, nh);
  put_i32(s, nd);
  put_i32(s, np);
  s.resize(12 + 24 * static_cast<std::size_t>(nh * nd * np));
  std::size_t at = 12;
  for (int c = 0; c < 3; ++c)
    for (int ih = 0; ih < nh; ++ih)
      for (int id = 0; id < nd; ++id)
        for (int ip = 0; ip < np; ++ip) {
          const auto u = std::bit_cast<std::uint64_t>(stored(ih, id, ip, c));
          for (int k = 0; k < 8; ++k) s[at++] = static_cast<char>((u >> (8 * k)) & 0xff);
        }
  return s;
}

TabulatedParts read_bytes(std::string bytes) {
  std::istringstream in(std::move(bytes));
  return read_merl(in, "t.binary");
}

// The scale factors of the database (Matusik et al. 2003): R 1/1500, G 1.15/1500, B 1.66/1500.
double expected(int ih, int id, int ip, int channel_rgb) {
  static constexpr double kScale[3] = {1.0 / 1500, 1.15 / 1500, 1.66 / 1500};
  return stored(ih, id, ip, channel_rgb) * kScale[channel_rgb];
}

TEST(Merl, TinyFileNodesAndScales) {
  const int nh = 4, nd = 3, np = 6;
  const auto parts = read_bytes(merl_file(nh, nd, np));
  ASSERT_TRUE(parts.brdf);
  const auto& t = *parts.brdf;
  EXPECT_EQ(t.param(), TableParam::half_difference);
  EXPECT_TRUE(t.reduction().reciprocal);
  EXPECT_EQ(t.wavelengths(), std::vector<double>(kRgbWavelengthsNm.begin(), kRgbWavelengthsNm.end()));
  // Non-linear θh nodes 90°·(k/n)², linear θd over 90°, φd over 180°.
  EXPECT_EQ(t.axis(0), (std::vector<double>{0, 90.0 / 16, 90.0 * 4 / 16, 90.0 * 9 / 16}));
  EXPECT_EQ(t.axis(2), (std::vector<double>{0, 30, 60}));
  EXPECT_EQ(t.axis(3), (std::vector<double>{0, 30, 60, 90, 120, 150}));
  for (int ih = 0; ih < nh; ++ih)
    for (int id = 0; id < nd; ++id)
      for (int ip = 0; ip < np; ++ip) {
        const auto i0 = static_cast<std::size_t>(ih), i2 = static_cast<std::size_t>(id),
                   i3 = static_cast<std::size_t>(ip);
        EXPECT_DOUBLE_EQ(t.at(i0, 0, i2, i3, 0), expected(ih, id, ip, 2));  // blue
        EXPECT_DOUBLE_EQ(t.at(i0, 0, i2, i3, 1), expected(ih, id, ip, 1));
        EXPECT_DOUBLE_EQ(t.at(i0, 0, i2, i3, 2), expected(ih, id, ip, 0));  // red
      }
}

// Directions built from the half-difference angles of a node evaluate to that node, through
// TabulatedBsdf on the three-point grid.
TEST(Merl, EvaluatesDirectionsAtNodes) {
  const auto parts = read_bytes(merl_file(5, 6, 8));
  const WavelengthGrid g(std::vector<double>(kRgbWavelengthsNm.begin(), kRgbWavelengthsNm.end()));
  const TabulatedBsdf b(g, parts);
  std::vector<double> f(3);
  for (int ih = 1; ih < 5; ++ih)
    for (int id = 1; id < 5; ++id)
      for (int ip = 0; ip < 8; ++ip) {
        const double th = 90.0 * (ih / 5.0) * (ih / 5.0), td = 90.0 * id / 6.0, pd = 180.0 * ip / 8;
        Vec3 wi, wo;
        tabtest::from_half_difference(th, 40, td, pd, wi, wo);
        if (wi.z <= 0.01 || wo.z <= 0.01) continue;
        b.eval(wi, wo, f);
        EXPECT_NEAR(f[2], expected(ih, id, ip, 0), 1e-9) << ih << ' ' << id << ' ' << ip;
        EXPECT_NEAR(f[0], expected(ih, id, ip, 2), 1e-9);
        // Reciprocity: swapping wi and wo is φd + 180°, the same sample.
        b.eval(wo, wi, f);
        EXPECT_NEAR(f[2], expected(ih, id, ip, 0), 1e-9);
      }
}

// The database's resolution: check the index layout against the reference mapping
// (θh index = 90·sqrt(θh/90°), θd index = θd/1°, φd index = φd/1°).
TEST(Merl, DatabaseResolution) {
  const auto parts = read_bytes(merl_file(90, 90, 180));
  const auto& t = *parts.brdf;
  ASSERT_EQ(t.nodes(0), 90u);
  ASSERT_EQ(t.nodes(2), 90u);
  ASSERT_EQ(t.nodes(3), 180u);
  double f[3];
  for (const auto& [ih, id, ip] : {std::tuple{10, 20, 30}, std::tuple{45, 60, 179}, std::tuple{89, 0, 0}}) {
    const double th = 90.0 * (ih / 90.0) * (ih / 90.0);
    t.interpolate({th, 0, static_cast<double>(id), static_cast<double>(ip)}, f);
    EXPECT_NEAR(f[2], expected(ih, id, ip, 0), 1e-9 * expected(ih, id, ip, 0));
    EXPECT_NEAR(std::floor(std::sqrt(th / 90.0) * 90.0 + 1e-9), ih, 0);
  }
}

TEST(Merl, NegativeMarksBecomeZero) {
  std::string s = merl_file(2, 2, 2);
  // First R value (θh 0, θd 0, φd 0) set to the database's "unmeasured" mark.
  std::string neg;
  put_f64(neg, -1.0);
  s.replace(12, 8, neg);
  const auto p = read_bytes(s);
  EXPECT_EQ(p.brdf->at(0, 0, 0, 0, 2), 0.0);
  EXPECT_GT(p.brdf->at(0, 0, 0, 0, 1), 0.0);
}

TEST(Merl, MalformedFilesFail) {
  const std::string good = merl_file(2, 3, 4);
  std::string nan = good;
  {
    std::string v;
    put_f64(v, std::nan(""));
    nan.replace(12 + 8 * 5, 8, v);
  }
  std::string huge;
  put_i32(huge, 90);
  put_i32(huge, 90);
  put_i32(huge, 1 << 30);
  std::string big;  // valid dims, every one at the limit: refused by size, not allocated
  put_i32(big, 1024);
  put_i32(big, 1024);
  put_i32(big, 1024);
  std::string zero;
  put_i32(zero, 0);
  put_i32(zero, 90);
  put_i32(zero, 180);
  std::string neg;
  put_i32(neg, -90);
  put_i32(neg, 90);
  put_i32(neg, 180);
  const std::vector<std::pair<std::string, std::string>> cases{
      {"empty", ""},
      {"short header", good.substr(0, 7)},
      {"truncated", good.substr(0, good.size() - 3)},
      {"half the data", good.substr(0, 12 + 8 * 24)},
      {"trailing", good + "x"},
      {"nan", nan},
      {"huge dimension", huge + std::string(64, '\0')},
      {"too many samples", big},
      {"zero dimension", zero},
      {"negative dimension", neg},
  };
  for (const auto& c : cases) {  // not a structured binding: clang 14 cannot capture one
    const auto& [name, bytes] = c;
    const auto e = error_of([&] { read_bytes(c.second); });
    EXPECT_EQ(e.code(), Errc::parse_error) << name << ": " << e.what();
    EXPECT_EQ(std::string(e.what()).rfind("t.binary: byte ", 0), 0u) << name << ": " << e.what();
  }
  const auto e = error_of([&] { read_bytes(nan); });
  EXPECT_NE(std::string(e.what()).find("byte 52"), std::string::npos) << e.what();
}

}  // namespace
}  // namespace gonio::twin
