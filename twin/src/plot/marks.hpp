// What a plot's panels are drawn with, in device units on a Cairo context: text, line
// styles, markers and series (figure.cpp lays the panels out).
#pragma once

#include <cairo.h>

#include <cstddef>
#include <string>

#include "gonio/twin/detail/plot/scale.hpp"
#include "gonio/twin/plot.hpp"

namespace gonio::twin::plot {

struct Rect {
  double x = 0, y = 0, w = 0, h = 0;
  double right() const { return x + w; }
  double bottom() const { return y + h; }
  bool contains(double px, double py) const {
    return px >= x && px <= right() && py >= y && py <= bottom();
  }
};

void font(cairo_t* cr, double size, bool bold = false);
double text_width(cairo_t* cr, const std::string& s);
// The font size at which `s` fits `width` (at most `size`, at least `floor`), and `s` cut
// with an ellipsis at UTF-8 boundaries if it does not fit even then. Leaves that font set.
std::string fit_text(cairo_t* cr, std::string s, double width, double size, double floor,
                     bool bold = false);
// Draws `s` with its anchor at (x, y): ha = 0 left, 0.5 centre, 1 right; the vertical
// anchor is the middle of the font's cap height, so rows of labels line up.
void text(cairo_t* cr, const std::string& s, double x, double y, double ha);
double label_width(cairo_t* cr, const Label& l, double size);
void draw_label(cairo_t* cr, const Label& l, double x, double y, double ha, double size);

void set_color(cairo_t* cr, const Rgba& c);
void set_line_style(cairo_t* cr, LineStyle style, double width);
void draw_marker(cairo_t* cr, Marker m, bool filled, double x, double y, double size,
                 double line_width);
Rgba series_color(const Series& s, std::size_t index);
// Error bars, then the line, then the markers.
void draw_series(cairo_t* cr, const Series& s, std::size_t index, const Scale& sx,
                 const Scale& sy);

}  // namespace gonio::twin::plot
