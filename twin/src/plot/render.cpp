// Two spheres side by side: the true and the measured BSDF under the same light.
//
// Per pixel, `samples` sub-pixel positions; where one hits the sphere, the local frame is
// built from the normal (Frame::from_normal) and the BSDF is evaluated in it:
//   directional light:   r += π f(ωl, ωo) cos θl                 (eval)
//   environment:          r += level · f(ωi, ωo) cos θi / p(ωi)    (one sample_wi draw)
//                         r += level · weight                      (each delta lobe)
// r is radiance per channel relative to a white diffuser facing the light, so the spectra
// go through the colorimetry of reflectance factors under D65 (CIE 1931 2°, the observer of
// sRGB). XYZ is then scaled so that the grid's white lands exactly on the sRGB white
// (x, y) = (0.3127, 0.3290) of IEC 61966-2-1, so a flat spectrum renders neutral on any
// grid, and encoded as sRGB. Rows are shared among std::threads; each pixel seeds its own
// generator from (seed, x, y), which makes the result independent of the thread count and
// gives both spheres the same random numbers.
#include "gonio/twin/render.hpp"

#include <cairo.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/color.hpp"
#include "plot/cairo_util.hpp"

namespace gonio::twin {
namespace {

// SplitMix64 (Steele, Lea & Flood, "Fast splittable pseudorandom number generators",
// OOPSLA 2014): tiny state, good enough for a handful of draws per pixel.
class SplitMix {
 public:
  explicit SplitMix(std::uint64_t seed) : s_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (s_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }

 private:
  std::uint64_t s_;
};

// sRGB display white from its chromaticity (IEC 61966-2-1: x = 0.3127, y = 0.3290), Y = 1.
constexpr double kWhiteX = 0.3127 / 0.3290;
constexpr double kWhiteZ = (1 - 0.3127 - 0.3290) / 0.3290;

// Spectral radiance factors of one BSDF's grid → white-aligned XYZ (Y = 1 for white).
class ToXyz {
 public:
  explicit ToXyz(const WavelengthGrid& grid) {
    try {
      cm_.emplace(grid, Illuminant::get("D65"), Observer::get(ObserverKind::cie1931_2deg));
      sx_ = kWhiteX / (cm_->white().x / 100);
      sz_ = kWhiteZ / (cm_->white().z / 100);
    } catch (const Error& e) {
      if (e.code() != Errc::invalid_argument) throw;  // missing tables are a real error
      cm_.reset();  // no visible channel: grey from the channel mean
    }
  }
  Xyz operator()(std::span<const double> r) const {
    if (cm_) {
      const Xyz c = cm_->xyz(r);
      return {c.x / 100 * sx_, c.y / 100, c.z / 100 * sz_};
    }
    double mean = 0;
    for (double v : r) mean += v;
    mean /= static_cast<double>(std::max<std::size_t>(1, r.size()));
    return {kWhiteX * mean, mean, kWhiteZ * mean};
  }

 private:
  std::optional<Colorimeter> cm_;
  double sx_ = 1, sz_ = 1;
};

std::uint8_t to_byte(double encoded) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(encoded, 0.0, 1.0) * 255));
}

constexpr std::array<std::uint8_t, 3> kBackground{40, 40, 44};
constexpr std::array<std::uint8_t, 3> kCaption{225, 225, 225};

void check_range(const char* field, double v, double lo, double hi, std::string_view unit = {}) {
  if (!(v >= lo && v <= hi)) throw Error::out_of_range(fmt::format("render.{}", field), v, lo, hi, unit);
}

// Per-thread scratch for one sphere.
struct Side {
  const Bsdf* bsdf;
  const ToXyz* to_xyz;
  std::vector<double> f, sum;
  std::vector<DeltaLobe> lobes;
};

void draw_captions(Image& img, int size, int band, const RenderOptions& o) {
  using plot::ContextPtr;
  using plot::SurfacePtr;
  SurfacePtr s(cairo_image_surface_create(CAIRO_FORMAT_RGB24, img.width, band),
               cairo_surface_destroy);
  if (cairo_surface_status(s.get()) != CAIRO_STATUS_SUCCESS)
    throw Error(Errc::internal, "cannot create the caption surface");
  {
    ContextPtr cr(cairo_create(s.get()), cairo_destroy);
    cairo_set_source_rgb(cr.get(), kBackground[0] / 255.0, kBackground[1] / 255.0,
                         kBackground[2] / 255.0);
    cairo_paint(cr.get());
    detail::release_font_caches_at_exit();
    cairo_select_font_face(cr.get(), "DejaVu Sans", CAIRO_FONT_SLANT_NORMAL,
                           CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr.get(), std::max(9.0, 0.42 * band));
    cairo_set_source_rgb(cr.get(), kCaption[0] / 255.0, kCaption[1] / 255.0,
                         kCaption[2] / 255.0);
    const std::string* captions[] = {&o.left_caption, &o.right_caption};
    for (int k = 0; k < 2; ++k) {
      cairo_text_extents_t e;
      cairo_text_extents(cr.get(), captions[k]->c_str(), &e);
      cairo_move_to(cr.get(), k * size + 0.5 * size - 0.5 * e.x_advance,
                    0.5 * band - e.y_bearing - 0.5 * e.height);
      cairo_show_text(cr.get(), captions[k]->c_str());
    }
  }
  cairo_surface_flush(s.get());
  const unsigned char* data = cairo_image_surface_get_data(s.get());
  const int stride = cairo_image_surface_get_stride(s.get());
  for (int y = 0; y < band; ++y) {
    const auto* row =
        reinterpret_cast<const std::uint32_t*>(data + static_cast<std::ptrdiff_t>(y) * stride);
    for (int x = 0; x < img.width; ++x)
      img.set(x, size + y,
              {static_cast<std::uint8_t>(row[x] >> 16), static_cast<std::uint8_t>(row[x] >> 8),
               static_cast<std::uint8_t>(row[x])});
  }
}

}  // namespace

void RenderOptions::validate() const {
  check_range("size", size, 16, 4096, " px");
  check_range("light_theta", light_theta, 0, 180, "°");
  check_range("light_phi", light_phi, -360, 360, "°");
  check_range("environment", environment, 0, 100);
  check_range("samples", samples, 1, 4096);
  check_range("exposure", exposure, 1e-6, 1e6);
  check_range("threads", threads, 0, 1024);
  if (left_caption.size() > 200) throw Error::invalid("render.left_caption", "is longer than 200 bytes");
  if (right_caption.size() > 200) throw Error::invalid("render.right_caption", "is longer than 200 bytes");
}

Rendering render_spheres(const Bsdf& left, const Bsdf& right, const RenderOptions& o) {
  o.validate();
  const int size = o.size;
  const int band = std::max(20, size / 7);
  Rendering out;
  out.size = size;
  out.radius = 0.46 * size;
  out.background = kBackground;
  out.image = Image(2 * size, size + band, kBackground);
  out.luminance.assign(static_cast<std::size_t>(size) * 2 * static_cast<std::size_t>(size), 0);

  const ToXyz xyz_left(left.wavelengths()), xyz_right(right.wavelengths());
  const double th = o.light_theta * kDegToRad, ph = o.light_phi * kDegToRad;
  const Vec3 light{std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)};
  const Vec3 view{0, 0, 1};
  const double bg_linear[3] = {srgb_decode(kBackground[0] / 255.0),
                               srgb_decode(kBackground[1] / 255.0),
                               srgb_decode(kBackground[2] / 255.0)};
  const double c = 0.5 * size, radius = out.radius;

  std::atomic<int> next_row{0};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  const auto worker = [&] {
    try {
      Side sides[2] = {{&left, &xyz_left, {}, {}, {}}, {&right, &xyz_right, {}, {}, {}}};
      for (auto& s : sides) {
        s.f.resize(s.bsdf->channels());
        s.sum.resize(s.bsdf->channels());
      }
      for (int py = next_row++; py < size; py = next_row++) {
        for (int px = 0; px < size; ++px) {
          for (int k = 0; k < 2; ++k) {
            Side& s = sides[k];
            std::fill(s.sum.begin(), s.sum.end(), 0.0);
            // Same stream for both sides (common random numbers).
            SplitMix rng(o.seed * 0x9e3779b97f4a7c15ULL ^
                         (static_cast<std::uint64_t>(py) << 32 | static_cast<std::uint64_t>(px)));
            int hits = 0;
            for (int n = 0; n < o.samples; ++n) {
              const double jx = o.samples == 1 ? 0.5 : rng.uniform();
              const double jy = o.samples == 1 ? 0.5 : rng.uniform();
              const double u_lobe = rng.uniform();
              const Vec2 u{rng.uniform(), rng.uniform()};
              const double x = (px + jx - c) / radius, y = (c - (py + jy)) / radius;
              const double r2 = x * x + y * y;
              if (r2 > 1) continue;
              ++hits;
              const Vec3 normal{x, y, std::sqrt(std::max(0.0, 1 - r2))};
              const Frame frame = Frame::from_normal(normal);
              const Vec3 wo = frame.to_local(view);
              if (wo.z <= 0) continue;
              const Vec3 wl = frame.to_local(light);
              if (wl.z > 0) {
                s.bsdf->eval(wl, wo, s.f);
                for (std::size_t i = 0; i < s.f.size(); ++i) s.sum[i] += kPi * s.f[i] * wl.z;
              }
              if (o.environment > 0) {
                const auto smp = s.bsdf->sample_wi(wo, u_lobe, u);
                if (smp && smp->wi.z > 0 && smp->pdf > 0) {
                  s.bsdf->eval(smp->wi, wo, s.f);
                  const double w = o.environment * smp->wi.z / smp->pdf;
                  for (std::size_t i = 0; i < s.f.size(); ++i) s.sum[i] += w * s.f[i];
                }
                if (s.bsdf->has_delta()) {
                  s.bsdf->delta_lobes(wo, s.lobes);
                  for (const auto& lobe : s.lobes) {
                    if (lobe.wi.z <= 0 || lobe.weight.size() != s.sum.size()) continue;
                    for (std::size_t i = 0; i < s.sum.size(); ++i)
                      s.sum[i] += o.environment * lobe.weight[i];
                  }
                }
              }
            }
            const int gx = k * size + px;
            if (hits == 0) continue;  // background, already filled
            const double inv = 1.0 / o.samples;
            for (auto& v : s.sum) v *= inv;
            const Xyz xyz = (*s.to_xyz)(s.sum);
            out.luminance[static_cast<std::size_t>(py) * 2 * static_cast<std::size_t>(size) +
                          static_cast<std::size_t>(gx)] = static_cast<float>(xyz.y);
            const Rgb lin = xyz_to_linear_srgb(xyz);
            const double miss = static_cast<double>(o.samples - hits) * inv;
            const double rgb[3] = {lin.r, lin.g, lin.b};
            std::array<std::uint8_t, 3> px8{};
            for (int ch = 0; ch < 3; ++ch)
              px8[static_cast<std::size_t>(ch)] =
                  to_byte(srgb_encode(std::max(0.0, rgb[ch]) * o.exposure + miss * bg_linear[ch]));
            out.image.set(gx, py, px8);
          }
        }
      }
    } catch (...) {
      const std::lock_guard lock(failure_mutex);
      if (!failure) failure = std::current_exception();
      next_row = size;  // stop the others
    }
  };

  unsigned n = o.threads != 0 ? o.threads : std::max(1u, std::thread::hardware_concurrency());
  n = std::min<unsigned>(n, static_cast<unsigned>(size));
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < n; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);

  draw_captions(out.image, size, band, o);
  return out;
}

}  // namespace gonio::twin
