// Cairo helpers shared by the figure drawing, the PNG I/O and the sphere renders: owning
// pointers for surfaces and contexts, the status check that turns a Cairo failure into an
// io_error naming the file, and the release of font caches in sanitizer builds.
#pragma once

#include <cairo.h>

#include <memory>
#include <string>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio::twin {
namespace detail {
// Registers (once) the release of cairo's and fontconfig's font caches at exit in sanitizer
// builds, so that LeakSanitizer does not report them; does nothing otherwise.
void release_font_caches_at_exit();
}  // namespace detail

namespace plot {

using SurfacePtr = std::unique_ptr<cairo_surface_t, decltype(&cairo_surface_destroy)>;
using ContextPtr = std::unique_ptr<cairo_t, decltype(&cairo_destroy)>;

// Throws Error(io_error) "cannot <what> '<path>': <cairo's reason>" unless st is success.
inline void check(cairo_status_t st, const std::string& path, const char* what) {
  if (st != CAIRO_STATUS_SUCCESS)
    throw Error(Errc::io_error,
                fmt::format("cannot {} '{}': {}", what, path, cairo_status_to_string(st)));
}

}  // namespace plot
}  // namespace gonio::twin
