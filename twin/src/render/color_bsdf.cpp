#include "render/color_bsdf.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <thread>

#include "gonio/twin/detail/core/sobol.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/twin/color.hpp"

namespace gonio::twin::render {
namespace {

// sRGB display white from its chromaticity (IEC 61966-2-1: x = 0.3127, y = 0.3290), Y = 1.
constexpr double kWhiteX = 0.3127 / 0.3290;
constexpr double kWhiteZ = (1 - 0.3127 - 0.3290) / 0.3290;

constexpr int kAlbedoNodes = 91;                  // θo every 1°
constexpr std::uint64_t kAlbedoPoints = 1u << 13;  // RQMC points per node

// Radiance factors per channel → white-aligned XYZ weights: D65 and the CIE 1931 2°
// observer (the observer of sRGB), X and Z scaled so that a flat spectrum lands on the sRGB
// white whatever the grid. A grid without visible wavelengths renders grey (channel mean).
std::array<std::vector<double>, 3> color_weights(const WavelengthGrid& grid) {
  const std::size_t n = grid.size();
  std::array<std::vector<double>, 3> w;
  for (auto& v : w) v.assign(n, 0.0);
  std::optional<Colorimeter> cm;
  try {
    cm.emplace(grid, Illuminant::get("D65"), Observer::get(ObserverKind::cie1931_2deg));
  } catch (const Error& e) {
    if (e.code() != Errc::invalid_argument) throw;  // missing tables are a real error
  }
  if (!cm) {
    for (std::size_t c = 0; c < n; ++c) {
      w[0][c] = kWhiteX / static_cast<double>(n);
      w[1][c] = 1.0 / static_cast<double>(n);
      w[2][c] = kWhiteZ / static_cast<double>(n);
    }
    return w;
  }
  const double sx = kWhiteX / (cm->white().x / 100), sz = kWhiteZ / (cm->white().z / 100);
  for (std::size_t c = 0; c < n; ++c) {
    w[0][c] = cm->weights()[c].x / 100 * sx;
    w[1][c] = cm->weights()[c].y / 100;
    w[2][c] = cm->weights()[c].z / 100 * sz;
  }
  return w;
}

}  // namespace

ColorBsdf::ColorBsdf(const Bsdf& bsdf, bool color, bool moments, unsigned threads)
    : bsdf_(bsdf), color_(color), w_(color_weights(bsdf.wavelengths())) {
  if (const auto* tab = dynamic_cast<const TabulatedBsdf*>(&bsdf)) {
    const auto& parts = tab->parts();
    if (parts.brdf) {
      isotropic_ = parts.brdf->isotropic();
      // One table with three channels (X, Y, Z interleaved; their "wavelengths" 1, 2, 3 nm
      // are labels only), so that one interpolation locates the cell for all three.
      const BsdfTable on_grid = parts.brdf->resampled(bsdf.wavelengths().values());
      std::array<BsdfTable, 3> by_channel;
      for (std::size_t k = 0; k < 3; ++k) by_channel[k] = on_grid.weighted(w_[k]);
      const std::size_t nodes = by_channel[0].values().size();
      std::vector<double> xyz(3 * nodes);
      for (std::size_t i = 0; i < nodes; ++i)
        for (std::size_t k = 0; k < 3; ++k) xyz[3 * i + k] = std::max(0.0, by_channel[k].values()[i]);
      projected_.emplace_back(on_grid.param(), on_grid.axes(), std::vector<double>{1, 2, 3},
                              std::move(xyz), on_grid.reduction());
    } else {
      projected_.clear();  // specular parts only: nothing to interpolate
    }
    if (!parts.brdf && !parts.specular_reflectance) isotropic_ = true;
    if (parts.specular_reflectance && !parts.specular_reflectance->phi_i().empty())
      isotropic_ = false;
  }
  if (moments) build_albedo(threads);
}

Color ColorBsdf::eval(const Vec3& wi, const Vec3& wo) const {
  Color out{0, 0, 0};
  if (wi.z <= 0 || wo.z <= 0) return out;
  if (!projected_.empty()) {
    projected_.front().eval(wi, wo, out);
    if (!color_) out[0] = out[2] = 0;
    return out;
  }
  if (dynamic_cast<const TabulatedBsdf*>(&bsdf_) != nullptr) return out;  // no BRDF table
  thread_local std::vector<double> f;
  f.resize(bsdf_.channels());
  bsdf_.eval(wi, wo, f);
  for (int k = color_ ? 0 : 1; k < (color_ ? 3 : 2); ++k) {
    const auto& w = w_[static_cast<std::size_t>(k)];
    double s = 0;
    for (std::size_t c = 0; c < f.size(); ++c) s += w[c] * f[c];
    out[static_cast<std::size_t>(k)] = s;
  }
  return out;
}

void ColorBsdf::delta(const Vec3& wo, std::vector<std::pair<Vec3, Color>>& out) const {
  out.clear();
  if (!bsdf_.has_delta()) return;
  thread_local std::vector<DeltaLobe> lobes;
  bsdf_.delta_lobes(wo, lobes);
  for (const auto& lobe : lobes) {
    if (lobe.wi.z <= 0 || lobe.weight.size() != bsdf_.channels()) continue;
    Color c{0, 0, 0};
    for (int k = color_ ? 0 : 1; k < (color_ ? 3 : 2); ++k) {
      const auto& w = w_[static_cast<std::size_t>(k)];
      for (std::size_t i = 0; i < w.size(); ++i) c[static_cast<std::size_t>(k)] += w[i] * lobe.weight[i];
    }
    out.emplace_back(lobe.wi, c);
  }
}

void ColorBsdf::build_albedo(unsigned threads) {
  nodes_.assign(kAlbedoNodes, Node{});
  if (!isotropic_) return;
  const auto& table = detail::SobolTable::get(kAlbedoPoints);
  // One node per task; each node's points depend on the node alone (deterministic).
  const auto node = [&](int j) {
    const double t = std::min(89.5, 90.0 * j / (kAlbedoNodes - 1)) * kDegToRad;
    const Vec3 wo{std::sin(t), 0, std::cos(t)};
    std::uint32_t scramble[3];
    for (int d = 0; d < 3; ++d)
      scramble[d] = static_cast<std::uint32_t>(
          detail::mix64(0xa1bed0ull ^ detail::mix64(static_cast<std::uint64_t>(j) * 8 + static_cast<std::uint64_t>(d))));
    Node sum{};
    for (std::uint64_t i = 0; i < kAlbedoPoints; ++i) {
      double u[3];
      for (int d = 0; d < 3; ++d)
        u[d] = detail::to_unit(detail::owen_scramble(table[i * detail::kSobolDims + static_cast<std::uint64_t>(d)], scramble[d]));
      const auto s = sample(wo, u[0], {u[1], u[2]});
      if (!s || s->wi.z <= 0 || !(s->pdf > 0)) continue;
      const Color f = eval(s->wi, wo);
      for (std::size_t k = 0; k < 3; ++k) {
        const double w = f[k] * s->wi.z / s->pdf;
        sum.a[k] += w;
        sum.mx[k] += w * s->wi.x;
        sum.mz[k] += w * s->wi.z;
      }
    }
    const double inv = 1.0 / static_cast<double>(kAlbedoPoints);
    for (std::size_t k = 0; k < 3; ++k) {
      sum.a[k] *= inv;
      sum.mx[k] *= inv;
      sum.mz[k] *= inv;
    }
    nodes_[static_cast<std::size_t>(j)] = sum;
  };
  unsigned n = threads != 0 ? threads : std::max(1u, std::thread::hardware_concurrency());
  n = std::min<unsigned>(n, kAlbedoNodes);
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < n; ++t)
    pool.emplace_back([&, t] {
      for (int j = static_cast<int>(t); j < kAlbedoNodes; j += static_cast<int>(n)) node(j);
    });
  for (int j = 0; j < kAlbedoNodes; j += static_cast<int>(n)) node(j);
  for (auto& th : pool) th.join();
}

ColorBsdf::Moments ColorBsdf::moments(const Vec3& wo) const {
  const double t = std::acos(std::clamp(wo.z, 0.0, 1.0)) * kRadToDeg;
  const double x = t / 90.0 * (kAlbedoNodes - 1);
  const auto j = std::min<std::size_t>(static_cast<std::size_t>(x), kAlbedoNodes - 2);
  const double a = x - static_cast<double>(j);
  // The tabulated moment has wo at azimuth 0; rotate it to wo's azimuth.
  const double s = std::hypot(wo.x, wo.y);
  const double c_phi = s > 1e-12 ? wo.x / s : 1, s_phi = s > 1e-12 ? wo.y / s : 0;
  Moments m;
  for (std::size_t k = 0; k < 3; ++k) {
    const Node& n0 = nodes_[j];
    const Node& n1 = nodes_[j + 1];
    m.albedo[k] = (1 - a) * n0.a[k] + a * n1.a[k];
    const double mx = (1 - a) * n0.mx[k] + a * n1.mx[k];
    const double mz = (1 - a) * n0.mz[k] + a * n1.mz[k];
    m.moment[k] = {mx * c_phi, mx * s_phi, mz};
  }
  return m;
}

}  // namespace gonio::twin::render
