// render_sphere(): one sphere, every pixel estimated to the same relative standard error.
//
// Per pixel (its centre's surface point; twin/rendering.md has the derivation):
//   exact terms      π f(ωl, ωo) cos θl for a point key light; weight·L(ωi) per delta lobe;
//                    A·L̄ + g·(M − A·r): h(ω) = L̄ + g·(ω − r) is the dome to first order
//                    about the mirror direction r (L̄ its value, g its gradient), A and M
//                    the sampler's E[f cos/p_b] and E[f cos/p_b · ω]
//   per sample       BSDF sample ωi ~ p_b:  f cos θi / p_b · (L_dome(ωi) − h(ωi))
//                                          + w_b · f cos θi · L_emit(ωi) / p_b
//                    emitter sample ωe ~ p_e: w_e · f cos θe · L_emit(ωe) / p_e
//   with the power heuristic w_b = p_b² / (p_b² + p_e²), w_e = p_e² / (p_b² + p_e²).
// h is a control variate: its expectation under the sampler is known exactly, so subtracting
// it inside and adding it outside is unbiased, and it removes both the sampler's mismatch
// and the dome's gradient across the lobe — what is left is the dome's curvature.
// Samples come in small randomised QMC nets (RqmcNet); batches of about min_samples run until
// the standard error of Y, from the spread of the nets' means, reaches the target.
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <ctime>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

#include <fmt/format.h>

#include "gonio/twin/detail/core/sobol.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/twin/render.hpp"
#include "render/color_bsdf.hpp"
#include "render/quantile.hpp"
#include "render/scene.hpp"

namespace gonio::twin {
namespace {

void check_range(const char* field, double v, double lo, double hi, std::string_view unit = {}) {
  if (!(v >= lo && v <= hi))
    throw Error::out_of_range(fmt::format("render.{}", field), v, lo, hi, unit);
}

// SplitMix64 (Steele, Lea & Flood, "Fast splittable pseudorandom number generators",
// OOPSLA 2014): a tiny per-pixel generator.
class SplitMix {
 public:
  explicit SplitMix(std::uint64_t seed) : s_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (s_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }

 private:
  std::uint64_t s_;
};

using render::Color;

// One randomised net of 2^bits points for a pixel sample's six dimensions: (u1, u2) the BSDF
// direction and (u4, u5) the emitter direction each the first two Sobol dimensions, a
// (0, m, 2)-net, under its own Owen scramble (Owen 1995; hashed as in Burley, "Practical
// Hash-based Owen Scrambling", JCGT 2020); the emitter pair's point order is itself
// Owen-shuffled so that the two pairs are not stratified alike (Burley 2020). u0 and u3
// (lobe and emitter choice) are Sobol dimensions 2 and 3, stratified in one dimension.
// Every point is uniform on [0, 1)^6, so a net's mean is unbiased; nets drawn with
// independent scrambles are independent, so the spread of net means gives an honest
// standard error while each net integrates the smooth parts far better than 2^bits
// independent points (variance O(n^-3) for smooth 2-D integrands, Owen 1997).
class RqmcNet {
 public:
  RqmcNet(const std::vector<std::uint32_t>& sobol, SplitMix& rng, int bits)
      : sobol_(sobol), bits_(bits) {
    for (auto& k : seed_) k = static_cast<std::uint32_t>(rng.next() >> 32);
  }
  void point(std::uint32_t i, double u[6]) const {
    const auto& t = sobol_;
    const auto at = [&](std::uint32_t k, int d, int s) {
      return detail::to_unit(detail::owen_scramble(t[k * detail::kSobolDims + static_cast<std::size_t>(d)],
                                                   seed_[static_cast<std::size_t>(s)]));
    };
    const std::uint32_t j =
        bits_ == 0 ? 0 : detail::owen_scramble(i << (32 - bits_), seed_[6]) >> (32 - bits_);
    u[0] = at(i, 2, 0);
    u[1] = at(i, 0, 1);
    u[2] = at(i, 1, 2);
    u[3] = at(j, 3, 3);
    u[4] = at(j, 0, 4);
    u[5] = at(j, 1, 5);
  }

 private:
  const std::vector<std::uint32_t>& sobol_;
  int bits_;
  std::array<std::uint32_t, 7> seed_{};
};

constexpr int kCoverageGrid = 8;       // sub-pixel grid for the silhouette's coverage
constexpr int kSilhouetteBatches = 4;  // sample budget of partly covered pixels, in batches
// Points per randomised net (see RqmcNet): 1 makes the samples independent, larger nets
// integrate smooth parts better but leave fewer nets to estimate the error from.
constexpr int kNetPoints = 8;

void add(Color& acc, const Color& f, double w) {
  for (std::size_t k = 0; k < 3; ++k) acc[k] += w * f[k];
}

// h(ω) = L̄ + g·(ω − r), the dome to first order about the mirror direction r.
struct ControlVariate {
  double l_bar = 0;
  Vec3 r{}, g{};
};

// The stochastic part of a pixel: the sum of its samples' values, their number and the
// standard error of its luminance.
struct Estimate {
  Color sum{0, 0, 0};
  int samples = 0;
  double se = 0;
};

// What every pixel of one render shares, and the steps of one pixel.
struct SphereRender {
  const RenderOptions& o;
  const render::Scene& scene;
  const render::ColorBsdf& cb;
  double centre, radius;
  Vec3 view{0, 0, 1};
  bool stochastic, use_cv;
  double floor;
  // Samples come in nets of net_points (at most kNetPoints, and at least four nets per
  // batch so that the first check has a standard error to go on).
  int net_bits = 0;
  std::uint32_t net_points = 1;
  const std::vector<std::uint32_t>* sobol = nullptr;
  int nets_per_batch = 0;

  SphereRender(const RenderOptions& options, const render::Scene& sc, const render::ColorBsdf& b,
               const SphereImage& out)
      : o(options),
        scene(sc),
        cb(b),
        centre(0.5 * out.size),
        radius(out.radius),
        stochastic(sc.has_environment() || sc.has_emitters()),
        use_cv(b.isotropic() && b.has_moments()),
        floor(kLitFloor / options.exposure) {
    while ((2 << net_bits) <= kNetPoints && (4 << (net_bits + 1)) <= o.min_samples) ++net_bits;
    net_points = 1u << net_bits;
    sobol = &detail::SobolTable::get(net_points);
    nets_per_batch = (o.min_samples + static_cast<int>(net_points) - 1) >> net_bits;
  }

  // Sub-pixel points on the sphere's disk, of kCoverageGrid².
  int covered(int px, int py) const {
    int inside = 0;
    for (int sy = 0; sy < kCoverageGrid; ++sy)
      for (int sx = 0; sx < kCoverageGrid; ++sx) {
        const double x = (px + (sx + 0.5) / kCoverageGrid - centre) / radius;
        const double y = (centre - (py + (sy + 0.5) / kCoverageGrid)) / radius;
        inside += x * x + y * y <= 1;
      }
    return inside;
  }

  // The surface normal at the pixel centre, pulled onto the sphere on the silhouette.
  Vec3 shading_normal(int px, int py) const {
    double x = (px + 0.5 - centre) / radius, y = (centre - (py + 0.5)) / radius;
    const double r2 = x * x + y * y;
    if (r2 > 0.9999) {
      const double s = std::sqrt(0.9999 / r2);
      x *= s;
      y *= s;
    }
    return {x, y, std::sqrt(std::max(0.0, 1 - x * x - y * y))};
  }

  // The point key light and the delta lobes, exactly.
  Color exact_terms(const Frame& frame, const Vec3& wo,
                     std::vector<std::pair<Vec3, Color>>& lobes) const {
    Color fixed{0, 0, 0};
    if (scene.point_light()) {
      const Vec3 wl = frame.to_local(scene.key());
      if (wl.z > 0) add(fixed, cb.eval(wl, wo), kPi * wl.z);
    }
    if (cb.has_delta()) {
      cb.delta(wo, lobes);
      for (const auto& [wi, weight] : lobes) {
        const Vec3 w = frame.to_world(wi);
        add(fixed, weight, scene.environment(w) + scene.emitted(w));
      }
    }
    return fixed;
  }

  // h about the mirror direction, and its exact expectation A·L̄ + g·(M − A·r) added to fixed.
  ControlVariate control_variate(const Vec3& n, const Frame& frame, const Vec3& wo,
                                 Color& fixed) const {
    ControlVariate cv;
    cv.r = reflect(view, n);
    cv.l_bar = scene.environment(cv.r);
    constexpr double h = 1e-3;
    const Vec3& r = cv.r;
    cv.g = Vec3{scene.environment(r + Vec3{h, 0, 0}) - scene.environment(r - Vec3{h, 0, 0}),
                scene.environment(r + Vec3{0, h, 0}) - scene.environment(r - Vec3{0, h, 0}),
                scene.environment(r + Vec3{0, 0, h}) - scene.environment(r - Vec3{0, 0, h})} /
           (2 * h);
    const auto m = cb.moments(wo);
    for (std::size_t k = 0; k < 3; ++k)
      fixed[k] += m.albedo[k] * (cv.l_bar - dot(cv.g, r)) + dot(cv.g, frame.to_world(m.moment[k]));
    return cv;
  }

  // The sum of one net's samples: a BSDF sample and an emitter sample per point, combined by
  // the power heuristic.
  Color net_sum(const RqmcNet& net, const Frame& frame, const Vec3& wo,
                 const ControlVariate& cv) const {
    Color sum{0, 0, 0};
    for (std::uint32_t i = 0; i < net_points; ++i) {
      double u[6];
      net.point(i, u);
      if (const auto s = cb.sample(wo, u[0], {u[1], u[2]}); s && s->wi.z > 0 && s->pdf > 0) {
        const Vec3 w = frame.to_world(s->wi);
        double l = use_cv ? scene.environment(w) - cv.l_bar - dot(cv.g, w - cv.r)
                          : scene.environment(w);
        if (const double e = scene.emitted(w); e > 0) {
          const double pe = scene.emitter_pdf(w);
          l += e * s->pdf * s->pdf / (s->pdf * s->pdf + pe * pe);
        }
        if (l != 0) add(sum, cb.eval(s->wi, wo), s->wi.z * l / s->pdf);
      }
      if (scene.has_emitters()) {
        const auto es = scene.sample_emitter(u[3], {u[4], u[5]});
        const Vec3 wl = frame.to_local(es.w);
        if (wl.z > 0 && es.pdf > 0) {
          const double pb = cb.pdf(wo, wl);
          const double w = es.pdf * es.pdf / (es.pdf * es.pdf + pb * pb);
          add(sum, cb.eval(wl, wo), wl.z * es.radiance * w / es.pdf);
        }
      }
    }
    return sum;
  }

  // Batches of nets until the luminance's standard error reaches rel_se or the budget is spent.
  Estimate estimate(int px, int py, const Frame& frame, const Vec3& wo, const ControlVariate& cv,
                    const Color& fixed, int budget) const {
    Estimate e;
    double sum_y = 0, sum_y2 = 0;
    int n_nets = 0;
    SplitMix rng(detail::mix64(o.seed) ^ (static_cast<std::uint64_t>(py) << 32 |
                                          static_cast<std::uint64_t>(px)));
    for (;;) {
      for (int b = 0; b < nets_per_batch; ++b) {
        // One net: net_points scrambled Sobol points, its mean one independent sample of the
        // pixel for the standard error.
        const RqmcNet net(*sobol, rng, net_bits);
        const Color s = net_sum(net, frame, wo, cv);
        add(e.sum, s, 1);
        const double v = s[1] / net_points;
        sum_y += v;
        sum_y2 += v * v;
      }
      n_nets += nets_per_batch;
      e.samples = n_nets * static_cast<int>(net_points);
      const double nn = n_nets;
      const double mean = sum_y / nn;
      const double var = std::max(0.0, (sum_y2 / nn - mean * mean) * nn / (nn - 1));
      e.se = std::sqrt(var / nn);
      const double lum = fixed[1] + mean;
      if (e.se <= o.rel_se * std::max(lum, floor) || e.samples >= budget) return e;
    }
  }

  void pixel(int px, int py, SphereImage& out, std::vector<std::pair<Vec3, Color>>& lobes) const {
    const int inside = covered(px, py);
    if (inside == 0) return;
    const std::size_t idx = out.index(px, py);
    // Pixels the silhouette crosses are blended with the background and see the lobe at
    // grazing angles, where it converges slowest: they stop after kSilhouetteBatches.
    const int budget = inside == kCoverageGrid * kCoverageGrid
                           ? o.max_samples
                           : std::min(o.max_samples, kSilhouetteBatches * o.min_samples);
    out.coverage[idx] = static_cast<float>(inside) / (kCoverageGrid * kCoverageGrid);
    const Vec3 n = shading_normal(px, py);
    const Frame frame = Frame::from_normal(n);
    const Vec3 wo = frame.to_local(view);
    Color fixed = exact_terms(frame, wo, lobes);
    const ControlVariate cv = use_cv ? control_variate(n, frame, wo, fixed) : ControlVariate{};
    const Estimate e = stochastic ? estimate(px, py, frame, wo, cv, fixed, budget) : Estimate{};
    Color total = fixed;
    if (e.samples > 0) add(total, e.sum, 1.0 / e.samples);
    if (!o.color) {
      total[0] = 0.3127 / 0.3290 * total[1];
      total[2] = (1 - 0.3127 - 0.3290) / 0.3290 * total[1];
    }
    out.xyz[idx] = {total[0], total[1], total[2]};
    out.samples[idx] = static_cast<std::uint32_t>(e.samples);
    out.rel_se[idx] = static_cast<float>(e.se / std::max(total[1], floor));
  }
};

// Rows handed out one at a time to `threads` workers (0: one per core); the first failure
// stops them all and is rethrown.
void for_each_row(int rows, unsigned threads, const std::function<void(int)>& row) {
  std::atomic<int> next_row{0};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  const auto worker = [&] {
    try {
      for (int py = next_row++; py < rows; py = next_row++) row(py);
    } catch (...) {
      const std::lock_guard lock(failure_mutex);
      if (!failure) failure = std::current_exception();
      next_row = rows;  // stop the others
    }
  };
  unsigned nt = threads != 0 ? threads : std::max(1u, std::thread::hardware_concurrency());
  nt = std::min<unsigned>(nt, static_cast<unsigned>(rows));
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < nt; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
}

// Noise over the lit pixels fully on the sphere.
NoiseReport noise_of(const SphereImage& out, const RenderOptions& o) {
  std::vector<double> rel;
  double samples = 0;
  std::size_t on = 0;
  for (std::size_t i = 0; i < out.coverage.size(); ++i) {
    if (out.coverage[i] <= 0) continue;
    ++on;
    samples += out.samples[i];
    if (out.coverage[i] >= 1 && out.xyz[i].y * o.exposure >= kLitFloor) rel.push_back(out.rel_se[i]);
  }
  NoiseReport nr;
  nr.lit_pixels = rel.size();
  nr.mean_samples = on > 0 ? samples / static_cast<double>(on) : 0;
  if (!rel.empty()) {
    nr.median_rel_se = quantile(rel, 0.5);
    nr.p95_rel_se = quantile(rel, 0.95);
    nr.max_rel_se = *std::max_element(rel.begin(), rel.end());
    const auto ok = std::count_if(rel.begin(), rel.end(),
                                  [&](double r) { return r <= o.rel_se * (1 + 1e-9); });
    nr.converged_fraction = static_cast<double>(ok) / static_cast<double>(rel.size());
  }
  return nr;
}

}  // namespace

void Lighting::validate() const {
  check_range("light_theta", light_theta, 0, 180, "°");
  check_range("light_phi", light_phi, -360, 360, "°");
  check_range("light_size", light_size, 0, 45, "°");
  check_range("environment_level", environment_level, 0, 100);
}

void RenderOptions::validate() const {
  check_range("size", size, 16, 4096, " px");
  lighting.validate();
  check_range("rel_se", rel_se, 1e-4, 0.5);
  check_range("min_samples", min_samples, 2, 1 << 16);
  check_range("max_samples", max_samples, min_samples, 1 << 20);
  check_range("exposure", exposure, 1e-6, 1e6);
  check_range("delta_e_max", delta_e_max, 0.1, 100);
  check_range("threads", threads, 0, 1024);
}

SphereImage render_sphere(const Bsdf& bsdf, const RenderOptions& o) {
  o.validate();
  const auto t0 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  const render::Scene scene(o.lighting);
  // The control variate's tables are needed only under an environment.
  const render::ColorBsdf cb(bsdf, o.color, scene.has_environment(), o.threads);
  const int size = o.size;
  const std::size_t npx = static_cast<std::size_t>(size) * static_cast<std::size_t>(size);
  SphereImage out;
  out.size = size;
  out.radius = 0.46 * size;
  out.xyz.assign(npx, Xyz{});
  out.coverage.assign(npx, 0.0f);
  out.rel_se.assign(npx, 0.0f);
  out.samples.assign(npx, 0);
  const SphereRender r(o, scene, cb, out);
  for_each_row(size, o.threads, [&](int py) {
    std::vector<std::pair<Vec3, Color>> lobes;
    for (int px = 0; px < size; ++px) r.pixel(px, py, out, lobes);
  });
  out.noise = noise_of(out, o);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.cpu_seconds = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  return out;
}

}  // namespace gonio::twin
