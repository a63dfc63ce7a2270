// The render figure: sphere panels, ΔE00 maps, a scale bar and captions, drawn into one
// 8-bit sRGB image (pixels written directly; text and the scale's labels through Cairo).
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/render.hpp"
#include "gonio/twin/detail/plot/cairo_util.hpp"

namespace gonio::twin {
namespace {

constexpr std::array<std::uint8_t, 3> kCaption{225, 225, 225};

std::uint8_t to_byte(double encoded) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(encoded, 0.0, 1.0) * 255));
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

// Centred text lines in the box [x0, x0 + w) × [y0, y0 + h), shrunk to fit the width.
void draw_text(cairo_t* cr, const std::string& text, double x0, double y0, double w, double h,
               double max_font) {
  const auto lines = lines_of(text);
  if (lines.empty()) return;
  const double n = static_cast<double>(lines.size());
  double font = std::min(max_font, h / (1.3 * n));
  cairo_set_font_size(cr, font);
  double widest = 0;
  for (const auto& l : lines) {
    cairo_text_extents_t e;
    cairo_text_extents(cr, l.c_str(), &e);
    widest = std::max(widest, e.x_advance);
  }
  if (widest > 0.94 * w) font *= 0.94 * w / widest;
  cairo_set_font_size(cr, font);
  const double line_h = 1.25 * font, top = y0 + 0.5 * (h - n * line_h);
  for (std::size_t k = 0; k < lines.size(); ++k) {
    cairo_text_extents_t e;
    cairo_text_extents(cr, lines[k].c_str(), &e);
    cairo_move_to(cr, x0 + 0.5 * w - 0.5 * e.x_advance,
                  top + (static_cast<double>(k) + 0.5) * line_h - e.y_bearing - 0.5 * e.height);
    cairo_show_text(cr, lines[k].c_str());
  }
}

}  // namespace

Image compose_panels(const Panels& p, const RenderOptions& o) {
  if (p.spheres.empty() || p.spheres.size() != p.sphere_captions.size() ||
      p.maps.size() != p.map_captions.size())
    throw Error::invalid("render.panels", "every panel needs exactly one caption");
  const int size = p.spheres.front()->size;
  for (const auto* s : p.spheres)
    if (s->size != size) throw Error::invalid("render.panels", "spheres of different sizes");
  for (const auto* m : p.maps)
    if (m->size != size) throw Error::invalid("render.panels", "maps of different sizes");
  const int band = std::max(24, size / 6);
  const int bar_w = p.maps.empty() ? 0 : std::max(56, size / 5);
  const int panels = static_cast<int>(p.spheres.size() + p.maps.size());
  Image img(panels * size + bar_w, size + band, kRenderBackground);

  const Rgb bg{srgb_decode(kRenderBackground[0] / 255.0), srgb_decode(kRenderBackground[1] / 255.0),
               srgb_decode(kRenderBackground[2] / 255.0)};
  for (std::size_t k = 0; k < p.spheres.size(); ++k) {
    const SphereImage& s = *p.spheres[k];
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        const std::size_t i = s.index(x, y);
        const double cov = s.coverage[i];
        if (cov <= 0) continue;
        const Rgb c = display_rgb(s.xyz[i], o);
        img.set(static_cast<int>(k) * size + x, y,
                {to_byte(srgb_encode(cov * c.r + (1 - cov) * bg.r)),
                 to_byte(srgb_encode(cov * c.g + (1 - cov) * bg.g)),
                 to_byte(srgb_encode(cov * c.b + (1 - cov) * bg.b))});
      }
  }
  const auto mix = [](std::array<std::uint8_t, 3> a, std::array<std::uint8_t, 3> b, double t) {
    std::array<std::uint8_t, 3> out{};
    for (std::size_t c = 0; c < 3; ++c)
      out[c] = static_cast<std::uint8_t>(std::lround((1 - t) * b[c] + t * a[c]));
    return out;
  };
  for (std::size_t k = 0; k < p.maps.size(); ++k) {
    const DeltaEMap& m = *p.maps[k];
    const int x0 = static_cast<int>(p.spheres.size() + k) * size;
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(size) +
                              static_cast<std::size_t>(x);
        if (m.coverage[i] <= 0) continue;
        img.set(x0 + x, y, mix(delta_e_color(m.delta_e[i] / o.delta_e_max), kRenderBackground,
                               m.coverage[i]));
      }
  }
  // Scale bar: top = delta_e_max, bottom = 0.
  const int bar_x = panels * size + bar_w / 6, bar_wd = std::max(8, bar_w / 5);
  const int bar_top = size / 10, bar_bottom = size - size / 10;
  if (bar_w > 0)
    for (int y = bar_top; y <= bar_bottom; ++y) {
      const double t = static_cast<double>(bar_bottom - y) / (bar_bottom - bar_top);
      for (int x = bar_x; x < bar_x + bar_wd; ++x) img.set(x, y, delta_e_color(t));
    }

  // Text through Cairo, over a copy of the image.
  using plot::ContextPtr;
  using plot::SurfacePtr;
  SurfacePtr surf(cairo_image_surface_create(CAIRO_FORMAT_RGB24, img.width, img.height),
                  cairo_surface_destroy);
  if (cairo_surface_status(surf.get()) != CAIRO_STATUS_SUCCESS)
    throw Error(Errc::internal, "cannot create the render surface");
  cairo_surface_flush(surf.get());
  unsigned char* data = cairo_image_surface_get_data(surf.get());
  const int stride = cairo_image_surface_get_stride(surf.get());
  for (int y = 0; y < img.height; ++y) {
    auto* row = reinterpret_cast<std::uint32_t*>(data + static_cast<std::ptrdiff_t>(y) * stride);
    for (int x = 0; x < img.width; ++x) {
      const auto c = img.at(x, y);
      row[x] = std::uint32_t{c[0]} << 16 | std::uint32_t{c[1]} << 8 | c[2];
    }
  }
  cairo_surface_mark_dirty(surf.get());
  {
    ContextPtr cr(cairo_create(surf.get()), cairo_destroy);
    detail::release_font_caches_at_exit();
    cairo_select_font_face(cr.get(), "DejaVu Sans", CAIRO_FONT_SLANT_NORMAL,
                           CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_source_rgb(cr.get(), kCaption[0] / 255.0, kCaption[1] / 255.0, kCaption[2] / 255.0);
    const double max_font = std::max(10.0, 0.36 * band);
    int col = 0;
    for (const auto& cap : p.sphere_captions)
      draw_text(cr.get(), cap, col++ * size, size, size, band, max_font);
    for (const auto& cap : p.map_captions)
      draw_text(cr.get(), cap, col++ * size, size, size, band, max_font);
    if (bar_w > 0) {
      const double step = o.delta_e_max <= 2 ? 0.5 : o.delta_e_max <= 10 ? 1 : o.delta_e_max <= 20 ? 2 : o.delta_e_max <= 50 ? 5 : 10;
      const double font = std::max(9.0, std::min(0.28 * band, bar_w / 3.5));
      cairo_set_font_size(cr.get(), font);
      cairo_set_line_width(cr.get(), 1);
      for (double v = 0; v <= o.delta_e_max + 1e-9; v += step) {
        const double y = bar_bottom - v / o.delta_e_max * (bar_bottom - bar_top);
        cairo_move_to(cr.get(), bar_x + bar_wd, y + 0.5);
        cairo_line_to(cr.get(), bar_x + bar_wd + 4, y + 0.5);
        cairo_stroke(cr.get());
        const std::string label =
            step < 1 ? fmt::format("{:.1f}", v) : fmt::format("{:.0f}", v);
        cairo_move_to(cr.get(), bar_x + bar_wd + 6, y + 0.35 * font);
        cairo_show_text(cr.get(), label.c_str());
      }
      draw_text(cr.get(), "ΔE00", panels * size, size, bar_w, band, max_font);
    }
  }
  cairo_surface_flush(surf.get());
  for (int y = 0; y < img.height; ++y) {
    const auto* row =
        reinterpret_cast<const std::uint32_t*>(data + static_cast<std::ptrdiff_t>(y) * stride);
    for (int x = 0; x < img.width; ++x)
      img.set(x, y, {static_cast<std::uint8_t>(row[x] >> 16), static_cast<std::uint8_t>(row[x] >> 8),
                     static_cast<std::uint8_t>(row[x])});
  }
  return img;
}

Comparison render_comparison(const std::vector<const Bsdf*>& bsdfs,
                             const std::vector<std::string>& captions, const RenderOptions& o) {
  if (bsdfs.empty() || bsdfs.size() != captions.size())
    throw Error::invalid("render.captions", "needs one caption per BSDF");
  Comparison out;
  out.spheres.reserve(bsdfs.size());
  for (const auto* b : bsdfs) out.spheres.push_back(render_sphere(*b, o));
  Panels p;
  for (std::size_t k = 0; k < bsdfs.size(); ++k) {
    p.spheres.push_back(&out.spheres[k]);
    p.sphere_captions.push_back(captions[k]);
  }
  out.maps.reserve(bsdfs.size() - 1);
  for (std::size_t k = 1; k < bsdfs.size(); ++k) {
    out.maps.push_back(delta_e_map(out.spheres[0], out.spheres[k], o));
    const auto& st = out.maps.back().stats;
    p.map_captions.push_back(fmt::format("ΔE00 {} vs {}\nmean {:.2f} (noise {:.2f}) · p95 {:.2f} · max {:.1f}",
                                         captions[k], captions[0], st.mean, st.noise_mean, st.p95, st.max));
  }
  for (const auto& m : out.maps) p.maps.push_back(&m);
  out.image = compose_panels(p, o);
  return out;
}

}  // namespace gonio::twin
