// What a plot's panels are drawn with: text fitted and anchored, line styles, markers and
// a series' error bars, line and markers (marks.hpp).
#include "plot/marks.hpp"

#include <algorithm>
#include <numbers>

#include "gonio/twin/detail/plot/cairo_util.hpp"

namespace gonio::twin::plot {

// ---- text ------------------------------------------------------------------------------

void font(cairo_t* cr, double size, bool bold) {
  detail::release_font_caches_at_exit();
  cairo_select_font_face(cr, "DejaVu Sans", CAIRO_FONT_SLANT_NORMAL,
                         bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, size);
}

double text_width(cairo_t* cr, const std::string& s) {
  cairo_text_extents_t e;
  cairo_text_extents(cr, s.c_str(), &e);
  return e.x_advance;
}

// The font size at which `s` fits `width` (at most `size`, at least `floor`), and `s` cut
// with an ellipsis at UTF-8 boundaries if it does not fit even then. Leaves that font set.
std::string fit_text(cairo_t* cr, std::string s, double width, double size, double floor,
                     bool bold) {
  font(cr, size, bold);
  const double w = text_width(cr, s);
  if (w <= width) return s;
  font(cr, std::max(floor, size * width / w), bold);
  if (text_width(cr, s) <= width) return s;
  while (!s.empty() && text_width(cr, s + "…") > width) {
    s.pop_back();
    while (!s.empty() && (static_cast<unsigned char>(s.back()) & 0xC0) == 0x80) s.pop_back();
    if (!s.empty() && (static_cast<unsigned char>(s.back()) & 0x80) != 0) s.pop_back();
  }
  return s + "…";
}

// Draws `s` with its anchor at (x, y): ha = 0 left, 0.5 centre, 1 right; the vertical
// anchor is the middle of the font's cap height, so rows of labels line up.
void text(cairo_t* cr, const std::string& s, double x, double y, double ha) {
  cairo_font_extents_t fe;
  cairo_font_extents(cr, &fe);
  cairo_move_to(cr, x - ha * text_width(cr, s), y + 0.35 * fe.ascent);
  cairo_show_text(cr, s.c_str());
}

double label_width(cairo_t* cr, const Label& l, double size) {
  font(cr, size);
  double w = text_width(cr, l.base);
  if (!l.sup.empty()) {
    font(cr, size * 0.72);
    w += text_width(cr, l.sup);
    font(cr, size);
  }
  return w;
}

void draw_label(cairo_t* cr, const Label& l, double x, double y, double ha, double size) {
  const double w = label_width(cr, l, size);
  const double x0 = x - ha * w;
  font(cr, size);
  text(cr, l.base, x0, y, 0);
  if (!l.sup.empty()) {
    const double bw = text_width(cr, l.base);
    font(cr, size * 0.72);
    text(cr, l.sup, x0 + bw, y - 0.45 * size, 0);
    font(cr, size);
  }
}

// ---- drawing primitives -----------------------------------------------------------------

void set_color(cairo_t* cr, const Rgba& c) { cairo_set_source_rgba(cr, c.r, c.g, c.b, c.a); }

void set_line_style(cairo_t* cr, LineStyle style, double width) {
  cairo_set_line_width(cr, width);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  if (style == LineStyle::dashed) {
    const double d[] = {4 * width, 2.5 * width};
    cairo_set_dash(cr, d, 2, 0);
    cairo_set_line_cap(cr, CAIRO_LINE_CAP_BUTT);
  } else if (style == LineStyle::dotted) {
    const double d[] = {0, 2.2 * width};
    cairo_set_dash(cr, d, 2, 0);
    cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
  } else {
    cairo_set_dash(cr, nullptr, 0, 0);
    cairo_set_line_cap(cr, CAIRO_LINE_CAP_BUTT);
  }
}

void draw_marker(cairo_t* cr, Marker m, bool filled, double x, double y, double size,
                 double line_width) {
  const double r = 0.5 * size;
  cairo_new_path(cr);
  switch (m) {
    case Marker::none:
      return;
    case Marker::circle:
      cairo_arc(cr, x, y, r, 0, 2 * std::numbers::pi);
      break;
    case Marker::square:
      cairo_rectangle(cr, x - 0.85 * r, y - 0.85 * r, 1.7 * r, 1.7 * r);
      break;
    case Marker::triangle:
      cairo_move_to(cr, x, y - 1.1 * r);
      cairo_line_to(cr, x + r, y + 0.7 * r);
      cairo_line_to(cr, x - r, y + 0.7 * r);
      cairo_close_path(cr);
      break;
    case Marker::diamond:
      cairo_move_to(cr, x, y - 1.15 * r);
      cairo_line_to(cr, x + 0.9 * r, y);
      cairo_line_to(cr, x, y + 1.15 * r);
      cairo_line_to(cr, x - 0.9 * r, y);
      cairo_close_path(cr);
      break;
    case Marker::cross:
      cairo_move_to(cr, x - 0.8 * r, y - 0.8 * r);
      cairo_line_to(cr, x + 0.8 * r, y + 0.8 * r);
      cairo_move_to(cr, x + 0.8 * r, y - 0.8 * r);
      cairo_line_to(cr, x - 0.8 * r, y + 0.8 * r);
      filled = false;
      break;
    case Marker::plus:
      cairo_move_to(cr, x - r, y);
      cairo_line_to(cr, x + r, y);
      cairo_move_to(cr, x, y - r);
      cairo_line_to(cr, x, y + r);
      filled = false;
      break;
  }
  cairo_set_dash(cr, nullptr, 0, 0);
  cairo_set_line_width(cr, std::max(1.0, 0.8 * line_width));
  if (filled) {
    cairo_fill(cr);
  } else if (m == Marker::cross || m == Marker::plus) {
    cairo_stroke(cr);
  } else {  // open marker: white inside so lines underneath do not show through
    cairo_save(cr);
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_fill_preserve(cr);
    cairo_restore(cr);
    cairo_stroke(cr);
  }
}

Rgba series_color(const Series& s, std::size_t index) {
  return s.color ? *s.color : palette_color(index);
}

// ---- series ----------------------------------------------------------------------------

void draw_series(cairo_t* cr, const Series& s, std::size_t index, const Scale& sx,
                 const Scale& sy) {
  const Rgba c = series_color(s, index);
  set_color(cr, c);
  if (!s.sigma.empty()) {
    set_line_style(cr, LineStyle::solid, std::max(0.8, 0.6 * s.line_width));
    const double cap = std::max(2.0, 0.45 * s.marker_size);
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!sx.valid(s.x[i]) || !sy.valid(s.y[i]) || !(s.sigma[i] > 0)) continue;
      const double x = sx.map(s.x[i]);
      const double lo = s.y[i] - s.sigma[i];
      // On a log axis a bar reaching zero runs off the bottom of the plot (clipped).
      const double y0 = sy.valid(lo) ? sy.map(lo) : sy.p0 + 10;
      const double y1 = sy.map(s.y[i] + s.sigma[i]);
      cairo_move_to(cr, x, y0);
      cairo_line_to(cr, x, y1);
      cairo_move_to(cr, x - cap, y0);
      cairo_line_to(cr, x + cap, y0);
      cairo_move_to(cr, x - cap, y1);
      cairo_line_to(cr, x + cap, y1);
    }
    cairo_stroke(cr);
  }
  if (s.line != LineStyle::none) {
    set_line_style(cr, s.line, s.line_width);
    bool pen = false;
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!sx.valid(s.x[i]) || !sy.valid(s.y[i])) {
        pen = false;
        continue;
      }
      const double x = sx.map(s.x[i]), y = sy.map(s.y[i]);
      if (pen) cairo_line_to(cr, x, y);
      else cairo_move_to(cr, x, y);
      pen = true;
    }
    cairo_stroke(cr);
  }
  if (s.marker != Marker::none) {
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!sx.valid(s.x[i]) || !sy.valid(s.y[i])) continue;
      draw_marker(cr, s.marker, s.marker_filled, sx.map(s.x[i]), sy.map(s.y[i]), s.marker_size,
                  s.line_width);
    }
  }
}

}  // namespace gonio::twin::plot
