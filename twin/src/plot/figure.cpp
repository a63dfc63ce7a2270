// Line plots through Cairo: the layout and drawing of a Figure and its writing as PNG, SVG
// or PDF.
//
// One drawing routine serves every format: Cairo's image surface (written as PNG), its SVG
// surface and its PDF surface. Layout is computed from text extents so that tick labels,
// axis labels and the legend never overlap; the legend goes to the inside corner that
// covers the fewest data points (none, ideally), otherwise outside on the right. Scales
// and tick positions come from scale.hpp, text, markers and series from marks.cpp; 8-bit
// images and their PNG I/O are in image.cpp.
#include <cairo-pdf.h>
#include <cairo-svg.h>
#include <cairo.h>
#include <dlfcn.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <memory>
#include <mutex>
#include <numbers>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/plot.hpp"
#include "gonio/twin/detail/plot/cairo_util.hpp"
#include "gonio/twin/detail/plot/scale.hpp"
#include "plot/marks.hpp"

namespace gonio::twin {
namespace detail {

#if defined(__SANITIZE_ADDRESS__)
// Sanitizer builds only: cairo's toy-font cache and fontconfig's configuration live for the
// whole process and LeakSanitizer reports them at exit. Release them first (cairo documents
// cairo_debug_reset_static_data for memory checkers; FcFini is looked up at run time since
// fontconfig is only an indirect dependency). Handlers run in reverse order of
// registration, so this one runs before the leak check.
void release_font_caches_at_exit() {
  static std::once_flag once;
  std::call_once(once, [] {
    std::atexit([] {
      cairo_debug_reset_static_data();
      using FcFiniFn = void (*)();
      if (void* sym = ::dlsym(RTLD_DEFAULT, "FcFini"))
        reinterpret_cast<FcFiniFn>(sym)();
    });
  });
}
#else
void release_font_caches_at_exit() {}
#endif

}  // namespace detail

namespace {

using plot::check;
using plot::ContextPtr;
using plot::Label;
using plot::Scale;
using plot::SurfacePtr;
using plot::Tick;
using plot::axis_title;
using plot::make_scale;
using plot::ticks;
// What a panel is drawn with (marks.hpp).
using plot::Rect;
using plot::draw_label;
using plot::draw_marker;
using plot::draw_series;
using plot::fit_text;
using plot::font;
using plot::label_width;
using plot::series_color;
using plot::set_color;
using plot::set_line_style;
using plot::text;
using plot::text_width;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---- legend --------------------------------------------------------------------------

struct LegendBox {
  Rect rect;
  std::vector<std::size_t> entries;  // indices of labelled series
  double row = 0, sample = 0;
};

LegendBox legend_size(cairo_t* cr, const Panel& p, double size) {
  LegendBox box;
  font(cr, size);
  double w = 0;
  for (std::size_t i = 0; i < p.series.size(); ++i) {
    if (p.series[i].label.empty()) continue;
    box.entries.push_back(i);
    w = std::max(w, text_width(cr, p.series[i].label));
  }
  box.row = 1.55 * size;
  box.sample = 2.6 * size;
  box.rect.w = 0.7 * size + box.sample + 0.6 * size + w + 0.8 * size;
  box.rect.h = box.row * static_cast<double>(box.entries.size()) + 0.6 * size;
  return box;
}

// How many data points, error-bar ends and line samples fall inside `r` (device units).
int covered(const Rect& r, const Panel& p, const Scale& sx, const Scale& sy) {
  int n = 0;
  const Rect grown{r.x - 4, r.y - 4, r.w + 8, r.h + 8};
  for (const auto& s : p.series) {
    double px = kNaN, py = kNaN;
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!sx.valid(s.x[i]) || !sy.valid(s.y[i])) {
        px = kNaN;
        continue;
      }
      const double x = sx.map(s.x[i]), y = sy.map(s.y[i]);
      if (grown.contains(x, y)) ++n;
      if (!s.sigma.empty() && s.sigma[i] > 0) {
        for (double v : {s.y[i] - s.sigma[i], s.y[i] + s.sigma[i]})
          if (sy.valid(v) && grown.contains(x, sy.map(v))) ++n;
      }
      if (s.line != LineStyle::none && std::isfinite(px)) {  // sample the segment
        const double len = std::hypot(x - px, y - py);
        const int steps = std::min(2000, static_cast<int>(len / 3));
        for (int k = 1; k < steps; ++k) {
          const double t = static_cast<double>(k) / steps;
          if (grown.contains(px + t * (x - px), py + t * (y - py))) ++n;
        }
      }
      px = x;
      py = y;
    }
  }
  return n;
}

void draw_legend(cairo_t* cr, const LegendBox& box, const Panel& p, double size) {
  const Rect& r = box.rect;
  cairo_set_dash(cr, nullptr, 0, 0);
  cairo_rectangle(cr, r.x, r.y, r.w, r.h);
  cairo_set_source_rgba(cr, 1, 1, 1, 0.92);
  cairo_fill_preserve(cr);
  cairo_set_source_rgb(cr, 0.6, 0.6, 0.6);
  cairo_set_line_width(cr, 0.8);
  cairo_stroke(cr);
  font(cr, size);
  double y = r.y + 0.3 * size + 0.5 * box.row;
  for (std::size_t i : box.entries) {
    const Series& s = p.series[i];
    const Rgba c = series_color(s, i);
    const double x0 = r.x + 0.7 * size;
    set_color(cr, c);
    if (s.line != LineStyle::none) {
      set_line_style(cr, s.line, s.line_width);
      cairo_move_to(cr, x0, y);
      cairo_line_to(cr, x0 + box.sample, y);
      cairo_stroke(cr);
    }
    if (!s.sigma.empty()) {  // a small error bar says "± σ"
      set_line_style(cr, LineStyle::solid, 1);
      const double xm = x0 + 0.5 * box.sample, h = 0.42 * box.row;
      cairo_move_to(cr, xm, y - h);
      cairo_line_to(cr, xm, y + h);
      cairo_move_to(cr, xm - 3, y - h);
      cairo_line_to(cr, xm + 3, y - h);
      cairo_move_to(cr, xm - 3, y + h);
      cairo_line_to(cr, xm + 3, y + h);
      cairo_stroke(cr);
    }
    draw_marker(cr, s.marker, s.marker_filled, x0 + 0.5 * box.sample, y,
                std::min(s.marker_size, box.row * 0.8), s.line_width);
    cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
    text(cr, s.label, x0 + box.sample + 0.6 * size, y, 0);
    y += box.row;
  }
}

// ---- figure ----------------------------------------------------------------------------

struct Fonts {
  double base, title, label, tick, legend;
};

Fonts fonts_for(const Figure& f) {
  const double base = std::clamp(std::min(f.width, f.height) / 45, 10.0, 18.0);
  return {base, base * 1.3, base * 1.05, base * 0.9, base * 0.9};
}

// The title across the top; returns where the panels start.
double draw_title(cairo_t* cr, const Figure& f, const Fonts& fs) {
  if (f.title.empty()) return 0.8 * fs.base;
  const auto title = fit_text(cr, f.title, 0.96 * f.width, fs.title, 0.55 * fs.title, true);
  cairo_set_source_rgb(cr, 0, 0, 0);
  text(cr, title, 0.5 * f.width, 1.3 * fs.title, 0.5);
  return 2.4 * fs.title;
}

// The notes' column: as wide as its longest line at the legend's size, at most a third.
// Returns the width left to the panels.
double draw_notes(cairo_t* cr, const Figure& f, const Fonts& fs, double top) {
  if (f.notes.empty()) return f.width;
  font(cr, fs.legend);
  double w = 0;
  for (const auto& n : f.notes) w = std::max(w, text_width(cr, n));
  const double column = std::min(w, f.width / 3 - 1.2 * fs.base);
  double size = fs.legend;
  if (w > column) size = std::max(0.6 * fs.legend, fs.legend * column / w);
  const double line = 1.35 * size;
  const double width = f.width - column - 1.2 * fs.base;
  cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
  double y = top + fs.base;
  for (const auto& n : f.notes) {
    if (y > f.height - 0.5 * line) break;
    const auto shown = fit_text(cr, n, column, size, size);
    text(cr, shown, width + 0.4 * fs.base, y, 0);
    y += line;
  }
  return width;
}

// Where a panel goes: its share of the figure, the plot inside it, its scales, ticks and
// legend.
struct Layout {
  Scale sx, sy;
  std::vector<Tick> tx, ty;
  Rect area, plot;
  LegendBox legend;

  void map_axes() {
    sx.p0 = plot.x;
    sx.p1 = plot.right();
    sy.p0 = plot.bottom();
    sy.p1 = plot.y;
  }
};

// The legend in the corner it covers the fewest points in, or beside the plot when every
// corner covers some (automatic); the plot narrows for a legend outside it.
void place_legend(cairo_t* cr, const Panel& p, Layout& l, const Fonts& fs) {
  l.legend = legend_size(cr, p, fs.legend);
  LegendPlacement where = p.legend;
  if (l.legend.entries.empty()) where = LegendPlacement::none;
  const double inset = 0.6 * fs.base;
  const auto corner = [&](LegendPlacement c) {
    Rect r = l.legend.rect;
    const bool right = c == LegendPlacement::upper_right || c == LegendPlacement::lower_right;
    const bool upper = c == LegendPlacement::upper_right || c == LegendPlacement::upper_left;
    r.x = right ? l.plot.right() - inset - r.w : l.plot.x + inset;
    r.y = upper ? l.plot.y + inset : l.plot.bottom() - inset - r.h;
    return r;
  };
  if (where == LegendPlacement::automatic) {
    where = LegendPlacement::outside_right;
    int best = std::numeric_limits<int>::max();
    for (auto c : {LegendPlacement::upper_right, LegendPlacement::upper_left,
                   LegendPlacement::lower_right, LegendPlacement::lower_left}) {
      const Rect r = corner(c);
      if (r.w > l.plot.w * 0.6 || r.h > l.plot.h * 0.8) continue;
      const int n = covered(r, p, l.sx, l.sy);
      if (n < best) {
        best = n;
        where = c;
      }
    }
    if (best > 0) where = LegendPlacement::outside_right;
  }
  if (where == LegendPlacement::outside_right) {
    l.plot.w -= l.legend.rect.w + inset;
    l.map_axes();
    l.legend.rect.x = l.plot.right() + inset;
    l.legend.rect.y = l.plot.y;
  } else if (where != LegendPlacement::none) {
    l.legend.rect = corner(where);
  } else {
    l.legend.entries.clear();
  }
}

// Scales and tick labels first: the left margin is shared so that x axes line up.
std::vector<Layout> lay_out(cairo_t* cr, const Figure& f, const Fonts& fs, double top,
                            double width) {
  std::vector<Layout> layouts(f.panels.size());
  double total_ratio = 0;
  for (const auto& p : f.panels) total_ratio += p.height_ratio;
  const double available = f.height - top;
  double y = top;
  double left = 0;
  for (std::size_t k = 0; k < f.panels.size(); ++k) {
    const Panel& p = f.panels[k];
    Layout& l = layouts[k];
    l.area = {0, y, width, available * p.height_ratio / total_ratio};
    y += l.area.h;
    l.sx = make_scale(p.x, p.series, false);
    l.sy = make_scale(p.y, p.series, true);
    l.ty = ticks(l.sy, l.area.h * 0.7);
    double wmax = 0;
    for (const auto& t : l.ty) wmax = std::max(wmax, label_width(cr, t.label, fs.tick));
    const double label_band = p.y.label.empty() && p.y.unit.empty() ? 0 : 1.9 * fs.label;
    left = std::max(left, 0.8 * fs.base + label_band + wmax + 0.7 * fs.tick);
  }
  for (std::size_t k = 0; k < f.panels.size(); ++k) {
    const Panel& p = f.panels[k];
    Layout& l = layouts[k];
    const double head = p.title.empty() ? 0.9 * fs.base : 2.0 * fs.label;
    const double foot = 1.6 * fs.tick + (p.x.label.empty() && p.x.unit.empty() ? 0.4 * fs.base
                                                                             : 2.0 * fs.label);
    l.plot = {left, l.area.y + head, width - left - 1.6 * fs.base, l.area.h - head - foot};
    l.map_axes();
    place_legend(cr, p, l, fs);
    l.tx = ticks(l.sx, l.plot.w);
  }
  return layouts;
}

// The grid at major ticks, then the reference lines.
void draw_grid(cairo_t* cr, const Panel& p, const Layout& l) {
  const Rect& r = l.plot;
  cairo_set_line_width(cr, 0.6);
  cairo_set_source_rgb(cr, 0.88, 0.88, 0.88);
  for (const auto& t : l.tx) {
    if (!t.major) continue;
    const double x = std::round(l.sx.map(t.v)) + 0.5;
    cairo_move_to(cr, x, r.y);
    cairo_line_to(cr, x, r.bottom());
  }
  for (const auto& t : l.ty) {
    if (!t.major) continue;
    const double yy = std::round(l.sy.map(t.v)) + 0.5;
    cairo_move_to(cr, r.x, yy);
    cairo_line_to(cr, r.right(), yy);
  }
  cairo_stroke(cr);
  cairo_set_source_rgb(cr, 0.45, 0.45, 0.45);
  cairo_set_line_width(cr, 1.0);
  for (double v : p.y_reference_lines) {
    if (!l.sy.valid(v) || v < std::min(l.sy.lo, l.sy.hi) || v > std::max(l.sy.lo, l.sy.hi))
      continue;
    cairo_move_to(cr, r.x, l.sy.map(v));
    cairo_line_to(cr, r.right(), l.sy.map(v));
  }
  cairo_stroke(cr);
}

// The frame, its ticks and their labels; returns the widest y tick label.
double draw_frame(cairo_t* cr, const Layout& l, const Fonts& fs) {
  const Rect& r = l.plot;
  cairo_set_dash(cr, nullptr, 0, 0);
  cairo_set_source_rgb(cr, 0, 0, 0);
  cairo_set_line_width(cr, 1.0);
  cairo_rectangle(cr, r.x, r.y, r.w, r.h);
  cairo_stroke(cr);
  const double major = 0.5 * fs.base, minor = 0.28 * fs.base;
  for (const auto& t : l.tx) {
    const double x = l.sx.map(t.v);
    cairo_move_to(cr, x, r.bottom());
    cairo_line_to(cr, x, r.bottom() - (t.major ? major : minor));
  }
  for (const auto& t : l.ty) {
    const double yy = l.sy.map(t.v);
    cairo_move_to(cr, r.x, yy);
    cairo_line_to(cr, r.x + (t.major ? major : minor), yy);
  }
  cairo_stroke(cr);
  for (const auto& t : l.tx)
    if (!t.label.base.empty())
      draw_label(cr, t.label, l.sx.map(t.v), r.bottom() + 0.95 * fs.tick, 0.5, fs.tick);
  double wmax = 0;
  for (const auto& t : l.ty) {
    if (t.label.base.empty()) continue;
    wmax = std::max(wmax, label_width(cr, t.label, fs.tick));
    draw_label(cr, t.label, r.x - 0.5 * fs.tick, l.sy.map(t.v), 1, fs.tick);
  }
  return wmax;
}

// The axis titles (the y one beside the widest tick label) and the panel's title.
void draw_titles(cairo_t* cr, const Panel& p, const Rect& r, const Fonts& fs, double wmax) {
  font(cr, fs.label);
  const auto xt = axis_title(p.x);
  if (!xt.empty()) text(cr, xt, r.x + 0.5 * r.w, r.bottom() + 1.6 * fs.tick + 1.0 * fs.label, 0.5);
  const auto yt = axis_title(p.y);
  if (!yt.empty()) {
    cairo_save(cr);
    cairo_translate(cr, r.x - 0.5 * fs.tick - wmax - 0.9 * fs.label, r.y + 0.5 * r.h);
    cairo_rotate(cr, -std::numbers::pi / 2);
    text(cr, yt, 0, 0, 0.5);
    cairo_restore(cr);
  }
  if (!p.title.empty()) {
    font(cr, fs.label, true);
    text(cr, p.title, r.x + 0.5 * r.w, r.y - 0.9 * fs.label, 0.5);
  }
}

void draw_panel(cairo_t* cr, const Panel& p, const Layout& l, const Fonts& fs) {
  const Rect& r = l.plot;
  cairo_set_dash(cr, nullptr, 0, 0);
  draw_grid(cr, p, l);
  // series, clipped to the plot area
  cairo_save(cr);
  cairo_rectangle(cr, r.x, r.y, r.w, r.h);
  cairo_clip(cr);
  for (std::size_t i = 0; i < p.series.size(); ++i) draw_series(cr, p.series[i], i, l.sx, l.sy);
  cairo_restore(cr);
  const double wmax = draw_frame(cr, l, fs);
  draw_titles(cr, p, r, fs, wmax);
  if (!l.legend.entries.empty()) draw_legend(cr, l.legend, p, fs.legend);
}

void draw_figure(cairo_t* cr, const Figure& f) {
  const Fonts fs = fonts_for(f);
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);
  const double top = draw_title(cr, f, fs);
  const double width = draw_notes(cr, f, fs, top);
  const auto layouts = lay_out(cr, f, fs, top, width);
  for (std::size_t k = 0; k < f.panels.size(); ++k) draw_panel(cr, f.panels[k], layouts[k], fs);
}

std::string lower_ext(const std::string& path) {
  const auto dot = path.find_last_of('.');
  const auto slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return {};
  std::string e = path.substr(dot + 1);
  for (auto& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

void check_range(const std::string& field, double v, double lo, double hi) {
  if (!(v >= lo && v <= hi)) throw Error::out_of_range(field, v, lo, hi);
}

}  // namespace
Rgba palette_color(std::size_t index) {
  // Okabe & Ito (2008), "Color Universal Design"; yellow last (weak on white).
  static constexpr std::array<std::array<int, 3>, 8> kColors{{{0, 114, 178},
                                                              {213, 94, 0},
                                                              {0, 158, 115},
                                                              {204, 121, 167},
                                                              {230, 159, 0},
                                                              {86, 180, 233},
                                                              {0, 0, 0},
                                                              {240, 228, 66}}};
  const auto& c = kColors[index % kColors.size()];
  return {c[0] / 255.0, c[1] / 255.0, c[2] / 255.0, 1};
}

void Figure::validate() const {
  check_range("width", width, 100, 20000);
  check_range("height", height, 100, 20000);
  if (panels.empty() || panels.size() > 4)
    throw Error(Errc::out_of_range,
                fmt::format("panels has {} entries, allowed 1 to 4", panels.size()), "panels");
  for (std::size_t k = 0; k < panels.size(); ++k) {
    const Panel& p = panels[k];
    const std::string pf = fmt::format("panels[{}]", k);
    check_range(pf + ".height_ratio", p.height_ratio, 0.05, 20);
    for (const auto& [axis, name] : {std::pair{&p.x, "x"}, std::pair{&p.y, "y"}}) {
      const std::string af = fmt::format("{}.{}", pf, name);
      if (axis->min && !std::isfinite(*axis->min))
        throw Error::invalid(af + ".min", "must be finite");
      if (axis->max && !std::isfinite(*axis->max))
        throw Error::invalid(af + ".max", "must be finite");
      if (axis->log && axis->min && !(*axis->min > 0))
        throw Error::out_of_range(af + ".min", *axis->min, std::numeric_limits<double>::min(),
                                  std::numeric_limits<double>::max());
      if (axis->log && axis->max && !(*axis->max > 0))
        throw Error::out_of_range(af + ".max", *axis->max, std::numeric_limits<double>::min(),
                                  std::numeric_limits<double>::max());
      if (axis->min && axis->max && !(*axis->max > *axis->min))
        throw Error::invalid(af, fmt::format("max {:g} must be above min {:g}", *axis->max,
                                             *axis->min));
    }
    for (std::size_t i = 0; i < p.series.size(); ++i) {
      const Series& s = p.series[i];
      const std::string sf = fmt::format("{}.series[{}]", pf, i);
      if (s.x.size() != s.y.size())
        throw Error::invalid(sf + ".y", fmt::format("has {} values for {} x values",
                                                    s.y.size(), s.x.size()));
      if (!s.sigma.empty() && s.sigma.size() != s.y.size())
        throw Error::invalid(sf + ".sigma", fmt::format("has {} values for {} y values",
                                                        s.sigma.size(), s.y.size()));
      for (std::size_t j = 0; j < s.sigma.size(); ++j)
        if (!(s.sigma[j] >= 0) || !std::isfinite(s.sigma[j]))
          throw Error::invalid(fmt::format("{}.sigma[{}]", sf, j), "must be finite and >= 0");
      check_range(sf + ".line_width", s.line_width, 0.1, 50);
      check_range(sf + ".marker_size", s.marker_size, 0.5, 100);
      if (s.color)
        for (double c : {s.color->r, s.color->g, s.color->b, s.color->a})
          check_range(sf + ".color", c, 0, 1);
    }
  }
}

ImageFormat image_format_from_path(const std::string& path) {
  const auto e = lower_ext(path);
  if (e == "png") return ImageFormat::png;
  if (e == "svg") return ImageFormat::svg;
  if (e == "pdf") return ImageFormat::pdf;
  throw Error::invalid("path", fmt::format("'{}' does not end in .png, .svg or .pdf", path));
}

void write_figure(const Figure& figure, const std::string& path) {
  figure.validate();
  const ImageFormat format = image_format_from_path(path);
  SurfacePtr surface(nullptr, cairo_surface_destroy);
  if (format == ImageFormat::png) {
    surface.reset(cairo_image_surface_create(CAIRO_FORMAT_RGB24,
                                             static_cast<int>(std::lround(figure.width)),
                                             static_cast<int>(std::lround(figure.height))));
  } else if (format == ImageFormat::svg) {
    surface.reset(cairo_svg_surface_create(path.c_str(), figure.width, figure.height));
  } else {
    surface.reset(cairo_pdf_surface_create(path.c_str(), figure.width, figure.height));
  }
  check(cairo_surface_status(surface.get()), path, "create");
  {
    ContextPtr cr(cairo_create(surface.get()), cairo_destroy);
    draw_figure(cr.get(), figure);
    check(cairo_status(cr.get()), path, "draw");
  }
  if (format == ImageFormat::png)
    check(cairo_surface_write_to_png(surface.get(), path.c_str()), path, "write");
  cairo_surface_finish(surface.get());
  check(cairo_surface_status(surface.get()), path, "write");
}

}  // namespace gonio::twin
