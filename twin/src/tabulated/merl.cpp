// MERL BRDF database files (.binary): reader.
//
// Format: W. Matusik, H. Pfister, M. Brand, L. McMillan, "A Data-Driven Reflectance Model",
// ACM Trans. Graph. 22(3), 2003, and the database's reference reader (BRDFRead.cpp): three
// little-endian int32 giving the resolution in θh, θd and φd (90, 90, 180), then three blocks
// (R, G, B) of that many little-endian doubles, φd varying fastest, then θd, then θh. A
// stored value times the channel's scale (1/1500, 1.15/1500, 1.66/1500) is f in sr⁻¹. The
// θh index is non-linear, k = 90·sqrt(θh / 90°), which concentrates samples near the
// specular peak; θd and φd are linear, φd over [0°, 180°) because the BRDF is reciprocal.
// Negative values mark samples the measurement could not reach; they become 0.
//
// The table keeps the database's nodes (θh = 90°·(k/n)², θd = 90°·k/n, φd = 180°·k/n) in the
// half-difference parametrization with the reciprocity reduction, and interpolates
// multilinearly between them. The three channels become a spectrum at kRgbWavelengthsNm.
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <istream>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf_io.hpp"

namespace gonio::twin {
namespace {

constexpr std::int32_t kMaxDim = 1024;
constexpr std::array<double, 3> kScale{1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};  // R, G, B

[[noreturn]] void fail(std::string_view source, std::uint64_t offset, std::string_view what) {
  throw Error(Errc::parse_error, fmt::format("{}: byte {}: {}", source, offset, what), "merl");
}

}  // namespace

TabulatedParts read_merl(std::istream& in, std::string_view source) {
  unsigned char head[12];
  in.read(reinterpret_cast<char*>(head), sizeof head);
  if (in.gcount() != sizeof head)
    fail(source, 0, fmt::format("the header needs 12 bytes, the file has {}", in.gcount()));
  std::array<std::int32_t, 3> dim{};
  static constexpr std::array<std::string_view, 3> kNames{"theta_h", "theta_d", "phi_d"};
  for (int k = 0; k < 3; ++k) {
    const unsigned char* b = head + 4 * k;
    const std::uint32_t u = std::uint32_t{b[0]} | std::uint32_t{b[1]} << 8 |
                            std::uint32_t{b[2]} << 16 | std::uint32_t{b[3]} << 24;
    dim[static_cast<std::size_t>(k)] = std::bit_cast<std::int32_t>(u);
    if (dim[static_cast<std::size_t>(k)] < 1 || dim[static_cast<std::size_t>(k)] > kMaxDim)
      fail(source, static_cast<std::uint64_t>(4 * k),
           fmt::format("{} resolution {} is outside [1, {}] (the database uses 90, 90, 180)",
                       kNames[static_cast<std::size_t>(k)], dim[static_cast<std::size_t>(k)],
                       kMaxDim));
  }
  const auto n_h = static_cast<std::size_t>(dim[0]), n_d = static_cast<std::size_t>(dim[1]),
             n_p = static_cast<std::size_t>(dim[2]);
  const std::size_t n = n_h * n_d * n_p;
  if (3 * n > BsdfTable::kMaxValues)
    fail(source, 0, fmt::format("{} × {} × {} samples exceed the size limit", n_h, n_d, n_p));

  // Read progressively: storage follows the bytes actually present, not the header.
  std::vector<double> raw;
  raw.reserve(std::min<std::size_t>(3 * n, 1 << 16));
  char buf[8 * 1024];
  while (raw.size() < 3 * n) {
    const std::size_t want = std::min<std::size_t>(3 * n - raw.size(), sizeof buf / 8);
    in.read(buf, static_cast<std::streamsize>(want * 8));
    const auto got = static_cast<std::size_t>(in.gcount());
    if (got != want * 8)
      fail(source, 12 + 8 * raw.size() + got,
           fmt::format("the data end after {} of {} values", raw.size() + got / 8, 3 * n));
    for (std::size_t i = 0; i < want; ++i) {
      std::uint64_t u = 0;
      for (int k = 7; k >= 0; --k)
        u = u << 8 | static_cast<unsigned char>(buf[8 * i + static_cast<std::size_t>(k)]);
      const double x = std::bit_cast<double>(u);
      if (!std::isfinite(x))
        fail(source, 12 + 8 * (raw.size()),
             fmt::format("value {} of channel {} is not finite", raw.size() % n,
                         "RGB"[raw.size() / n]));
      raw.push_back(x);
    }
  }
  if (in.peek() != std::char_traits<char>::eof())
    fail(source, 12 + 8 * 3 * n, "trailing bytes after the three colour blocks");

  BsdfTable::Axes axes;
  for (std::size_t k = 0; k < n_h; ++k) {
    const double x = static_cast<double>(k) / static_cast<double>(n_h);
    axes.p0.push_back(90.0 * x * x);
  }
  for (std::size_t k = 0; k < n_d; ++k)
    axes.p2.push_back(90.0 * static_cast<double>(k) / static_cast<double>(n_d));
  for (std::size_t k = 0; k < n_p; ++k)
    axes.p3.push_back(180.0 * static_cast<double>(k) / static_cast<double>(n_p));

  // Table order: channel fastest (B, G, R), then θh, θd, φd.
  std::vector<double> values(3 * n);
  for (std::size_t ip = 0; ip < n_p; ++ip)
    for (std::size_t id = 0; id < n_d; ++id)
      for (std::size_t ih = 0; ih < n_h; ++ih) {
        const std::size_t merl = (ih * n_d + id) * n_p + ip;
        const std::size_t dst = ((ip * n_d + id) * n_h + ih) * 3;
        for (std::size_t c = 0; c < 3; ++c) {
          const std::size_t rgb = 2 - c;  // table channel c is B, G, R
          values[dst + c] = std::max(0.0, raw[rgb * n + merl]) * kScale[rgb];
        }
      }
  TabulatedParts parts;
  try {
    parts.brdf = BsdfTable(TableParam::half_difference, std::move(axes),
                           {kRgbWavelengthsNm.begin(), kRgbWavelengthsNm.end()}, std::move(values),
                           {false, true});
  } catch (const Error& e) {  // e.g. a value beyond BsdfTable::kMaxF
    fail(source, 12, e.what());
  }
  return parts;
}

TabulatedParts read_merl(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(Errc::not_found, fmt::format("cannot open '{}'", path), "path");
  return read_merl(in, path);
}

}  // namespace gonio::twin
