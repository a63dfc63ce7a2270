#include <map>

#include <fmt/format.h>

#include "cli/error_map_plot.hpp"
#include "gonio/twin/plot.hpp"

namespace gonio::twin::cli {

void plot_error_map(const std::string& path, const std::vector<ErrorMapRow>& rows,
                    const std::string& title, bool log_y) {
  // One pair of series per incidence angle, in the plane of measurement only.
  std::map<double, std::vector<const ErrorMapRow*>> by_incidence;
  for (const auto& r : rows)
    if (r.geometry.in_measurement_plane()) by_incidence[r.geometry.theta_i].push_back(&r);

  Figure fig;
  fig.title = fmt::format("{} — true vs virtually measured", title);
  fig.width = 1000;
  fig.height = 700;
  fig.panels.reserve(2);  // the references below must survive the second emplace_back
  Panel& beta = fig.panels.emplace_back();
  beta.x = Axis("receiving angle θr", "°");
  beta.y = Axis("radiance factor β").logarithmic(log_y);
  beta.height_ratio = 2;
  Panel& err = fig.panels.emplace_back();
  err.x = Axis("receiving angle θr", "°");
  err.y = Axis("rel. error");
  err.y_reference_lines = {0};
  err.legend = LegendPlacement::none;

  std::size_t k = 0;
  for (const auto& [ti, list] : by_incidence) {
    std::vector<double> x, t, v, s, rel_x, rel;
    for (const auto* r : list) {
      x.push_back(r->geometry.theta_r);
      t.push_back(r->true_beta);
      v.push_back(r->virtual_beta);
      s.push_back(r->std_error);
      if (r->true_beta > 0) {
        rel_x.push_back(r->geometry.theta_r);
        rel.push_back((r->virtual_beta - r->true_beta) / r->true_beta);
      }
    }
    const auto color = palette_color(k++);
    auto& st = beta.series.emplace_back(fmt::format("θi = {}° true", ti), x, t);
    st.color = color;
    auto& sv = beta.series.emplace_back(fmt::format("θi = {}° virtual", ti), x, v, s);
    sv.color = color;
    sv.line = LineStyle::none;
    sv.marker = Marker::circle;
    sv.marker_size = 4;
    auto& se = err.series.emplace_back("", rel_x, rel);
    se.color = color;
  }
  write_figure(fig, path);
}

}  // namespace gonio::twin::cli
