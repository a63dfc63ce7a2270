// 8-bit sRGB images (gonio/twin/plot.hpp) and their PNG I/O through Cairo's image surfaces:
// the sphere renders write them, the tests read them back.
#include <cairo.h>

#include <cstddef>
#include <cstdint>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/twin/plot.hpp"
#include "gonio/twin/detail/plot/cairo_util.hpp"

namespace gonio::twin {

using plot::check;
using plot::ContextPtr;
using plot::SurfacePtr;

Image::Image(int w, int h, std::array<std::uint8_t, 3> fill) : width(w), height(h) {
  if (w < 0 || h < 0) throw Error::invalid("image", "negative size");
  rgb.resize(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3);
  for (std::size_t i = 0; i < rgb.size(); i += 3) {
    rgb[i] = fill[0];
    rgb[i + 1] = fill[1];
    rgb[i + 2] = fill[2];
  }
}

std::array<std::uint8_t, 3> Image::at(int x, int y) const {
  const auto i = (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                  static_cast<std::size_t>(x)) * 3;
  return {rgb.at(i), rgb.at(i + 1), rgb.at(i + 2)};
}

void Image::set(int x, int y, std::array<std::uint8_t, 3> c) {
  const auto i = (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                  static_cast<std::size_t>(x)) * 3;
  rgb.at(i) = c[0];
  rgb.at(i + 1) = c[1];
  rgb.at(i + 2) = c[2];
}

void write_png(const Image& image, const std::string& path) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgb.size() != static_cast<std::size_t>(image.width) *
                              static_cast<std::size_t>(image.height) * 3)
    throw Error::invalid("image", fmt::format("{}×{} image with {} bytes", image.width,
                                              image.height, image.rgb.size()));
  SurfacePtr s(cairo_image_surface_create(CAIRO_FORMAT_RGB24, image.width, image.height),
               cairo_surface_destroy);
  check(cairo_surface_status(s.get()), path, "create");
  cairo_surface_flush(s.get());
  unsigned char* data = cairo_image_surface_get_data(s.get());
  const int stride = cairo_image_surface_get_stride(s.get());
  for (int y = 0; y < image.height; ++y) {
    auto* row = reinterpret_cast<std::uint32_t*>(data + static_cast<std::ptrdiff_t>(y) * stride);
    for (int x = 0; x < image.width; ++x) {
      const auto c = image.at(x, y);
      row[x] = (std::uint32_t{c[0]} << 16) | (std::uint32_t{c[1]} << 8) | std::uint32_t{c[2]};
    }
  }
  cairo_surface_mark_dirty(s.get());
  check(cairo_surface_write_to_png(s.get(), path.c_str()), path, "write");
}

Image read_png(const std::string& path) {
  SurfacePtr src(cairo_image_surface_create_from_png(path.c_str()), cairo_surface_destroy);
  const auto st = cairo_surface_status(src.get());
  if (st == CAIRO_STATUS_FILE_NOT_FOUND)
    throw Error(Errc::not_found, fmt::format("PNG file '{}' not found", path));
  if (st != CAIRO_STATUS_SUCCESS)
    throw Error(Errc::parse_error,
                fmt::format("cannot read PNG '{}': {}", path, cairo_status_to_string(st)));
  const int w = cairo_image_surface_get_width(src.get());
  const int h = cairo_image_surface_get_height(src.get());
  // Composite over white into a known layout, whatever the PNG's colour type was.
  SurfacePtr dst(cairo_image_surface_create(CAIRO_FORMAT_RGB24, w, h), cairo_surface_destroy);
  {
    ContextPtr cr(cairo_create(dst.get()), cairo_destroy);
    cairo_set_source_rgb(cr.get(), 1, 1, 1);
    cairo_paint(cr.get());
    cairo_set_source_surface(cr.get(), src.get(), 0, 0);
    cairo_paint(cr.get());
  }
  cairo_surface_flush(dst.get());
  const unsigned char* data = cairo_image_surface_get_data(dst.get());
  const int stride = cairo_image_surface_get_stride(dst.get());
  Image img(w, h);
  for (int y = 0; y < h; ++y) {
    const auto* row =
        reinterpret_cast<const std::uint32_t*>(data + static_cast<std::ptrdiff_t>(y) * stride);
    for (int x = 0; x < w; ++x)
      img.set(x, y, {static_cast<std::uint8_t>(row[x] >> 16), static_cast<std::uint8_t>(row[x] >> 8),
                     static_cast<std::uint8_t>(row[x])});
  }
  return img;
}

}  // namespace gonio::twin
