// Line plots: files in every format, decodable PNGs of the requested size that show the
// data, legend placement that does not hide data, and clear errors.
#include "gonio/twin/plot.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "gonio/proto/error.hpp"
#include "gonio/test/temp_dir.hpp"

namespace gonio::twin {
namespace {

namespace fs = std::filesystem;

using TempDir = ::gonio::test::TempDir;

std::string head(const std::string& path, std::size_t n) {
  std::ifstream in(path, std::ios::binary);
  std::string s(n, '\0');
  in.read(s.data(), static_cast<std::streamsize>(n));
  s.resize(static_cast<std::size_t>(in.gcount()));
  return s;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string fmt_label(const char* what, double theta_i) {
  return std::string(what) + ", θi = " + std::to_string(static_cast<int>(theta_i)) + "°";
}

// β of a glossy sample in the plane of incidence: a peak at the specular angle.
double beta(double theta_i, double theta_r) {
  const double d = (theta_r - theta_i) / 6;
  return 0.05 + 20 * std::exp(-0.5 * d * d);
}

// Like the error-map figure: true curves and measured points with σ, per incidence
// angle, logarithmic β, and a second panel with the relative error.
Figure error_map_like() {
  Figure f;
  f.title = "β in the plane of incidence: true vs virtually measured";
  f.panels.resize(2);
  Panel& top = f.panels[0];
  top.x = Axis("receiving angle θr", "°");
  top.y = Axis("radiance factor β").logarithmic();
  top.height_ratio = 2;
  Panel& bottom = f.panels[1];
  bottom.x = top.x;
  bottom.y = Axis("relative error", "%");
  bottom.y_reference_lines = {0};
  std::size_t k = 0;
  for (double ti : {15.0, 45.0, 75.0}) {
    Series truth, meas, err;
    for (double tr = -80; tr <= 80; tr += 1) {
      truth.x.push_back(tr);
      truth.y.push_back(beta(ti, tr));
    }
    for (double tr = -80; tr <= 80; tr += 5) {
      const double m = beta(ti, tr) * (1 - 0.3 * std::exp(-std::pow((tr - ti) / 4, 2)));
      meas.x.push_back(tr);
      meas.y.push_back(m);
      meas.sigma.push_back(0.05 * m);
      err.x.push_back(tr);
      err.y.push_back(100 * (m / beta(ti, tr) - 1));
    }
    truth.label = fmt_label("true", ti);
    truth.color = palette_color(k);
    meas.label = fmt_label("measured", ti);
    meas.color = palette_color(k);
    meas.line = LineStyle::none;
    meas.marker = Marker::circle;
    err.color = palette_color(k);
    err.marker = Marker::square;
    err.line = LineStyle::dashed;
    top.series.push_back(truth);
    top.series.push_back(meas);
    bottom.series.push_back(err);
    ++k;
  }
  return f;
}

TEST(Plot, WritesPngSvgAndPdfByExtension) {
  const TempDir tmp;
  const Figure f = error_map_like();
  const std::string png = tmp.file("map.png"), svg = tmp.file("map.svg"),
                    pdf = tmp.file("map.PDF");
  write_figure(f, png);
  write_figure(f, svg);
  write_figure(f, pdf);
  ASSERT_TRUE(fs::exists(png));
  ASSERT_TRUE(fs::exists(svg));
  ASSERT_TRUE(fs::exists(pdf));
  EXPECT_EQ(head(png, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_EQ(head(pdf, 5), "%PDF-");
  EXPECT_EQ(head(svg, 5), "<?xml");
  EXPECT_NE(slurp(svg).find("<svg"), std::string::npos);

  const Image img = read_png(png);
  EXPECT_EQ(img.width, 900);
  EXPECT_EQ(img.height, 600);
  // Not blank: many pixels differ from the white background, in several colours.
  int non_white = 0, blueish = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const auto c = img.at(x, y);
      if (c != std::array<std::uint8_t, 3>{255, 255, 255}) ++non_white;
      if (c[2] > 150 && c[0] < 60) ++blueish;  // palette_color(0) = (0, 114, 178)
    }
  EXPECT_GT(non_white, 5000);
  EXPECT_GT(blueish, 200);
}

// A figure with fixed axes so that data positions are known in pixels: the plot area
// spans most of the image, and a thick red line at y = 5 runs across it.
Figure red_line(bool with_series) {
  Figure f;
  f.width = 400;
  f.height = 300;
  Panel& p = f.panels.emplace_back();
  p.x = Axis("x", "mm").range(0, 10);
  p.y = Axis("y").range(0, 10);
  if (with_series) {
    Series s;
    s.x = {0, 10};
    s.y = {5, 5};
    s.color = Rgba{1, 0, 0, 1};
    s.line_width = 6;
    p.series.push_back(s);
  }
  return f;
}

int count_red(const Image& img) {
  int n = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const auto c = img.at(x, y);
      if (c[0] > 200 && c[1] < 80 && c[2] < 80) ++n;
    }
  return n;
}

TEST(Plot, PixelsShowTheSeriesWhereItIsDrawn) {
  const TempDir tmp;
  write_figure(red_line(true), tmp.file("with.png"));
  write_figure(red_line(false), tmp.file("without.png"));
  const Image with = read_png(tmp.file("with.png"));
  const Image without = read_png(tmp.file("without.png"));
  ASSERT_EQ(with.width, 400);
  ASSERT_EQ(with.height, 300);
  EXPECT_EQ(count_red(without), 0);
  // A 6 px line across most of a 400 px wide image.
  EXPECT_GT(count_red(with), 6 * 250);
  // The red pixels sit in the middle column band, at mid height of the plot area.
  int column_red = 0;
  double mean_y = 0;
  for (int y = 0; y < with.height; ++y) {
    const auto c = with.at(with.width / 2, y);
    if (c[0] > 200 && c[1] < 80 && c[2] < 80) {
      ++column_red;
      mean_y += y;
    }
  }
  ASSERT_GE(column_red, 4);
  mean_y /= column_red;
  EXPECT_GT(mean_y, 0.3 * with.height);
  EXPECT_LT(mean_y, 0.7 * with.height);
}

// Red data covers three corners; a labelled blue point sits in the middle. The legend
// (only the blue entry) must go to the free lower-right corner and hide no red pixel.
Figure crowded(LegendPlacement where) {
  Figure f;
  f.width = 500;
  f.height = 360;
  Panel& p = f.panels.emplace_back();
  p.x = Axis("x").range(0, 10);
  p.y = Axis("y").range(0, 10);
  p.legend = where;
  Series top, low;
  for (double x = 0; x <= 10; x += 0.25) {
    top.x.push_back(x);
    top.y.push_back(9.6);
  }
  for (double x = 0; x <= 4.5; x += 0.25) {
    low.x.push_back(x);
    low.y.push_back(1);
  }
  for (auto* s : {&top, &low}) {
    s->color = Rgba{1, 0, 0, 1};
    s->line_width = 4;
    p.series.push_back(*s);
  }
  Series blue;
  blue.label = "a rather long legend entry";
  blue.x = {5};
  blue.y = {5};
  blue.line = LineStyle::none;
  blue.marker = Marker::diamond;
  blue.color = Rgba{0, 0, 1, 1};
  p.series.push_back(blue);
  return f;
}

TEST(Plot, LegendDoesNotCoverData) {
  const TempDir tmp;
  write_figure(crowded(LegendPlacement::none), tmp.file("none.png"));
  write_figure(crowded(LegendPlacement::automatic), tmp.file("auto.png"));
  write_figure(crowded(LegendPlacement::upper_right), tmp.file("ur.png"));
  const int bare = count_red(read_png(tmp.file("none.png")));
  ASSERT_GT(bare, 1000);
  EXPECT_EQ(count_red(read_png(tmp.file("auto.png"))), bare);
  // Forcing the legend onto data does hide some: the check above can fail.
  EXPECT_LT(count_red(read_png(tmp.file("ur.png"))), bare);
}

TEST(Plot, LogAxisSkipsNonPositiveValuesAndMarkersAllDraw) {
  const TempDir tmp;
  Figure f;
  Panel& p = f.panels.emplace_back();
  p.x = Axis("θr", "°");
  p.y = Axis("β").logarithmic();
  const Marker markers[] = {Marker::circle, Marker::square, Marker::triangle,
                            Marker::diamond, Marker::cross, Marker::plus};
  const LineStyle lines[] = {LineStyle::solid, LineStyle::dashed, LineStyle::dotted,
                             LineStyle::none};
  for (int k = 0; k < 6; ++k) {
    Series s;
    s.label = "series " + std::to_string(k);
    s.marker = markers[k];
    s.marker_filled = k % 2 == 0;
    s.line = lines[k % 4];
    for (int i = 0; i < 20; ++i) {
      s.x.push_back(i);
      s.y.push_back(i == 7 ? 0.0 : i == 8 ? -1.0 : std::pow(10.0, (i - 10) / 4.0 + k * 0.3));
      s.sigma.push_back(0.6 * s.y.back() > 0 ? 0.6 * s.y.back() : 0.0);
    }
    s.y[3] = std::nan("");  // a gap
    p.series.push_back(s);
  }
  write_figure(f, tmp.file("log.png"));
  const Image img = read_png(tmp.file("log.png"));
  EXPECT_EQ(img.width, 900);
  int non_white = 0;
  for (std::size_t i = 0; i < img.rgb.size(); i += 3)
    if (img.rgb[i] != 255 || img.rgb[i + 1] != 255 || img.rgb[i + 2] != 255) ++non_white;
  EXPECT_GT(non_white, 3000);
}

TEST(Plot, RejectsBadFiguresAndPaths) {
  const TempDir tmp;
  Figure f = red_line(true);
  try {
    write_figure(f, tmp.file("plot.gif"));
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::invalid_argument);
    EXPECT_EQ(e.field(), "path");
  }
  for (const char* ext : {"png", "svg", "pdf"}) {
    try {
      write_figure(f, tmp.file(std::string("missing-dir/plot.") + ext));
      ADD_FAILURE() << ext;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), Errc::io_error) << ext;
    }
  }
  f.panels[0].series[0].y.push_back(1);
  try {
    write_figure(f, tmp.file("plot.png"));
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "panels[0].series[0].y");
  }
  f = red_line(true);
  f.panels[0].series[0].sigma = {0.1, -1};
  try {
    f.validate();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "panels[0].series[0].sigma[1]");
  }
  f = red_line(true);
  f.width = 10;
  try {
    f.validate();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::out_of_range);
    EXPECT_EQ(e.field(), "width");
  }
  f = red_line(true);
  f.panels[0].y.log = true;  // min = 0 on a log axis
  EXPECT_THROW(f.validate(), Error);
  f = red_line(true);
  f.panels.clear();
  EXPECT_THROW(f.validate(), Error);
}

TEST(Image, PngRoundTripAndErrors) {
  const TempDir tmp;
  Image img(7, 5, {10, 20, 30});
  img.set(3, 2, {255, 0, 128});
  write_png(img, tmp.file("a.png"));
  const Image back = read_png(tmp.file("a.png"));
  EXPECT_EQ(back.width, 7);
  EXPECT_EQ(back.height, 5);
  EXPECT_EQ(back.rgb, img.rgb);
  try {
    read_png(tmp.file("nothing.png"));
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::not_found);
  }
  std::ofstream(tmp.file("junk.png")) << "not a png at all";
  try {
    read_png(tmp.file("junk.png"));
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::parse_error);
  }
  EXPECT_THROW(write_png(Image(), tmp.file("empty.png")), Error);
}

}  // namespace
}  // namespace gonio::twin

namespace gonio::twin {
namespace {

// Columns [x0, x1) of rows [y0, y1) that hold a dark (text) pixel.
int dark_columns(const Image& img, int x0, int x1, int y0, int y1) {
  int n = 0;
  for (int x = x0; x < x1; ++x)
    for (int y = y0; y < y1; ++y) {
      const auto c = img.at(x, y);
      if (c[0] < 128 && c[1] < 128 && c[2] < 128) {
        ++n;
        break;
      }
    }
  return n;
}

// A title far longer than the figure shrinks (then is cut with an ellipsis) instead of
// running off both ends; notes sit in their own column at the right, within the image, and
// the panels make room for them.
TEST(Plot, LongTitleAndNotesStayInsideTheImage) {
  TempDir tmp;
  auto f = error_map_like();
  f.width = 800;
  f.height = 500;
  std::string title = "fit of lambert:albedo=";
  for (int k = 0; k < 31; ++k) title += std::to_string(400 + 10 * k) + ":?,";
  title += "+coat:alpha=?,ior=?";
  f.title = title;
  write_figure(f, tmp.file("title.png"));
  const Image img = read_png(tmp.file("title.png"));
  // The title band: text close to both ends is cut off text; the shrunk title leaves a
  // margin of 2 % on each side.
  const int band = 30;
  EXPECT_EQ(dark_columns(img, 0, 10, 0, band), 0);
  EXPECT_EQ(dark_columns(img, img.width - 10, img.width, 0, band), 0);
  EXPECT_GT(dark_columns(img, 100, img.width - 100, 0, band), 300);  // the title is there

  auto g = error_map_like();
  g.width = 800;
  g.height = 500;
  for (int k = 0; k < 8; ++k) g.notes.push_back("lambert.albedo@" + std::to_string(400 + 10 * k) + " = 0.4321 ± 0.0012");
  g.notes.push_back("a note far longer than a third of the figure's width, which must be shrunk and then cut");
  write_figure(g, tmp.file("notes.png"));
  write_figure(error_map_like(), tmp.file("plain.png"));
  const Image with = read_png(tmp.file("notes.png"));
  // The right third holds the notes' text; without notes it holds the plot and legend, and
  // with them the plot area ends left of the column (its frame moves left).
  EXPECT_GT(dark_columns(with, 2 * with.width / 3 + 10, with.width - 5, 40, 200), 50);
  EXPECT_EQ(dark_columns(with, with.width - 3, with.width, 0, with.height), 0);
}

}  // namespace
}  // namespace gonio::twin
