// Line plots (PNG, SVG, PDF through Cairo) and 8-bit RGB images with PNG I/O.
//
// A Figure is a title and one or more Panels stacked top to bottom; a Panel has two axes
// (linear or logarithmic), any number of Series (line and/or markers, optional ±σ error
// bars) and a legend that is placed where it covers no data. The types are plain values:
// callers fill them and call write_figure(); nothing here knows about BSDFs.
//
//   Figure fig{.title = "β in the plane of incidence"};
//   Panel& p = fig.panels.emplace_back();
//   p.x = Axis("receiving angle θr", "°");
//   p.y = Axis("radiance factor β").logarithmic();
//   p.series.emplace_back("true", theta_r, beta);
//   p.series.emplace_back("measured", theta_r, beta_m, sigma_m).line = LineStyle::none;
//   write_figure(fig, "beta.png");   // format from the extension
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace gonio::twin {

// Colour with alpha, components in [0, 1] (sRGB-encoded, as drawn).
struct Rgba {
  double r = 0, g = 0, b = 0, a = 1;
};

// Series colours by index: the Okabe–Ito palette (distinguishable with colour-vision
// deficiencies), cycling.
Rgba palette_color(std::size_t index);

enum class LineStyle { none, solid, dashed, dotted };
enum class Marker { none, circle, square, triangle, diamond, cross, plus };

struct Series {
  Series() = default;
  Series(std::string legend, std::vector<double> xs, std::vector<double> ys,
         std::vector<double> sigmas = {})
      : label(std::move(legend)), x(std::move(xs)), y(std::move(ys)), sigma(std::move(sigmas)) {}

  std::string label;          // legend entry; empty: not in the legend
  std::vector<double> x, y;   // same size; a non-finite y breaks the line
  std::vector<double> sigma;  // ±σ error bars on y (>= 0); empty: none
  LineStyle line = LineStyle::solid;
  Marker marker = Marker::none;
  bool marker_filled = true;
  std::optional<Rgba> color;  // default: palette_color(index of the series in its panel)
  double line_width = 1.5;    // device units (px for PNG, pt for SVG/PDF)
  double marker_size = 6;     // diameter, device units
};

struct Axis {
  Axis() = default;
  Axis(std::string quantity, std::string unit_text = {})
      : label(std::move(quantity)), unit(std::move(unit_text)) {}
  Axis& range(double lo, double hi) {
    min = lo;
    max = hi;
    return *this;
  }
  Axis& logarithmic(bool on = true) {
    log = on;
    return *this;
  }

  std::string label;           // the quantity: "receiving angle θr"
  std::string unit;            // shown as "label (unit)"; empty: no unit
  std::optional<double> min;   // default: from the data (with σ), padded
  std::optional<double> max;
  bool log = false;            // base-10; values <= 0 are not drawn
};

enum class LegendPlacement {
  automatic,  // the inside corner covering no data, else outside on the right
  upper_right, upper_left, lower_left, lower_right,
  outside_right,
  none,
};

struct Panel {
  std::string title;                     // drawn above the panel's plot area; optional
  Axis x, y;
  std::vector<Series> series;
  LegendPlacement legend = LegendPlacement::automatic;
  std::vector<double> y_reference_lines;  // thin grey horizontal lines (e.g. 0 for errors)
  double height_ratio = 1;                // share of the figure height among panels
};

struct Figure {
  std::string title;
  double width = 900;   // px for PNG, pt for SVG / PDF
  double height = 600;
  std::vector<Panel> panels;  // 1 to 4, top to bottom
  // Lines of text in a column at the right of the panels (e.g. fitted parameters), at most
  // a third of the width: the font shrinks until the longest line fits, and a line still
  // too long is cut with an ellipsis. The title shrinks to the width the same way.
  std::vector<std::string> notes;

  // Throws gonio::Error naming the offending field ("panels[1].series[0].sigma").
  void validate() const;
};

enum class ImageFormat { png, svg, pdf };
// By extension (.png, .svg, .pdf, case-insensitive); Error(invalid_argument) otherwise.
ImageFormat image_format_from_path(const std::string& path);

// Draws and writes the figure. Errors: invalid_argument (figure or extension),
// io_error (file cannot be written).
void write_figure(const Figure& figure, const std::string& path);

// An 8-bit sRGB image, row-major, 3 bytes per pixel, row 0 at the top.
struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;

  Image() = default;
  Image(int w, int h, std::array<std::uint8_t, 3> fill = {0, 0, 0});
  std::array<std::uint8_t, 3> at(int x, int y) const;
  void set(int x, int y, std::array<std::uint8_t, 3> c);
};

// PNG through Cairo. write_png: io_error; read_png: not_found, parse_error (any PNG that
// Cairo decodes; transparency is composited over white).
void write_png(const Image& image, const std::string& path);
Image read_png(const std::string& path);

}  // namespace gonio::twin
