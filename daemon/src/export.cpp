// Scan export to CSV, JSON, IS-SA and SSDD (see export.hpp).
#include "gonio/daemon/export.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf_io.hpp"
#include "gonio/twin/color.hpp"
#include "gonio/twin/tabulated.hpp"

namespace gonio::daemon {
namespace {

std::string csv_number(double v) { return fmt::format("{:.9g}", v); }

std::string to_csv(const Scan& scan, const std::vector<PointRecord>& points, bool header = true) {
  std::string out;
  if (header) {
    out += fmt::format("# gonio scan {} sample {} exported {}\n", scan.id, scan.plan.sample_id,
                       utc::now());
    out += "index,geometry_index,repeat,theta_i,phi_i,theta_r,phi_r,actual_theta_i,actual_theta_r,"
           "wavelength_nm,measured,measured_u,predicted,predicted_se,z_max,delta_e00,diverged,"
           "flags,integration_ms\n";
  }
  for (const auto& p : points) {
    std::string flags;
    for (const auto& f : p.flags) flags += (flags.empty() ? "" : ";") + f;
    for (std::size_t c = 0; c < p.measured.size(); ++c) {
      out += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},", p.index, p.geometry_index,
                         p.repeat, csv_number(p.planned.theta_i), csv_number(p.planned.phi_i),
                         csv_number(p.planned.theta_r), csv_number(p.planned.phi_r),
                         csv_number(p.actual.theta_i), csv_number(p.actual.theta_r),
                         csv_number(p.measured.wavelengths[c]), csv_number(p.measured.values[c]),
                         csv_number(p.measured.std_uncertainty[c]));
      if (p.predicted && c < p.predicted->size())
        out += fmt::format("{},{},", csv_number(p.predicted->values[c]),
                           csv_number(p.predicted->std_uncertainty[c]));
      else
        out += ",,";
      // The integration time the point was read at (auto-ranging), empty when not known.
      out += fmt::format("{},{},{},{},{}\n", p.z_max ? csv_number(*p.z_max) : "",
                         p.delta_e00 ? csv_number(*p.delta_e00) : "", p.diverged ? 1 : 0, flags,
                         p.integration_ms ? csv_number(*p.integration_ms) : "");
    }
  }
  return out;
}

// The measured BRDF on an isotropic spherical grid.
twin::BsdfTable to_table(const Scan& scan, const std::vector<PointRecord>& points) {
  if (points.empty()) throw Error(Errc::unsupported, "the scan has no measured point to export");
  std::set<double> ti, to, sides;
  // (θi, θo, φo) → sum of f per channel and count.
  std::map<std::array<double, 3>, std::pair<std::vector<double>, int>> cells;
  const std::size_t channels = points.front().measured.size();
  for (const auto& p : points) {
    const auto& g = p.planned;
    if (!g.in_measurement_plane() || g.is_transmission())
      throw Error(Errc::unsupported,
                  fmt::format("point {} ({}) is not an in-plane reflection geometry; export csv "
                              "or json",
                              p.index, g.to_string()));
    const double theta_o = std::abs(g.theta_r);
    std::vector<double> sides_here;
    if (g.theta_r > 0) sides_here = {180.0};
    else if (g.theta_r < 0) sides_here = {0.0};
    else sides_here = {0.0, 180.0};  // the normal lies on both sides
    ti.insert(g.theta_i);
    to.insert(theta_o);
    for (double side : sides_here) {
      sides.insert(side);
      auto& cell = cells[{g.theta_i, theta_o, side}];
      if (cell.first.empty()) cell.first.assign(channels, 0.0);
      for (std::size_t c = 0; c < channels; ++c)
        cell.first[c] += std::max(0.0, p.measured.values[c]) / std::numbers::pi;
      ++cell.second;
    }
  }
  const std::vector<double> p0(ti.begin(), ti.end()), p2(to.begin(), to.end()),
      p3(sides.begin(), sides.end());
  std::vector<double> values(p0.size() * p2.size() * p3.size() * channels);
  for (std::size_t i3 = 0; i3 < p3.size(); ++i3)
    for (std::size_t i2 = 0; i2 < p2.size(); ++i2)
      for (std::size_t i0 = 0; i0 < p0.size(); ++i0) {
        const auto it = cells.find({p0[i0], p2[i2], p3[i3]});
        if (it == cells.end())
          throw Error(Errc::unsupported,
                      fmt::format("the scan is not a full grid: no point at θi = {:g}°, θr = "
                                  "{:g}°; export csv or json",
                                  p0[i0], p3[i3] > 90 ? p2[i2] : -p2[i2]));
        const std::size_t base = ((i3 * p2.size() + i2) * p0.size() + i0) * channels;
        for (std::size_t c = 0; c < channels; ++c)
          values[base + c] = it->second.first[c] / it->second.second;
      }
  twin::BsdfTable::Axes axes;
  axes.p0 = p0;
  axes.p2 = p2;
  axes.p3 = p3;
  return twin::BsdfTable(twin::TableParam::spherical, std::move(axes),
                         scan.plan.wavelengths.values(), std::move(values),
                         twin::TableReduction{true, false});
}

}  // namespace

ExportResult export_scan(const Scan& scan, const std::vector<PointRecord>& points,
                         std::string_view format) {
  ExportResult r;
  r.format = std::string(format);
  r.filename = fmt::format("scan-{}.{}", scan.id, format);
  if (format == "csv") {
    r.media_type = "text/csv";
    r.content = to_csv(scan, points);
  } else if (format == "json") {
    r.media_type = "application/json";
    r.content = nlohmann::json{{"scan", nlohmann::json(scan)}, {"points", points}}.dump(1);
  } else if (format == "bsdf" || format == "ssdd") {
    r.media_type = "text/plain";
    const auto table = to_table(scan, points);
    std::ostringstream os;
    const auto comment = fmt::format("gonio scan {} (sample {}), measured BRDF f = beta/pi",
                                     scan.id, scan.plan.sample_id);
    if (format == "bsdf") {
      // A spectral scan keeps its colour: IS-SA XYZ blocks (D65, 10° observer, Y = the
      // luminance factor), as gonio-twin convert writes them; a single channel is Monochrome.
      twin::IssaWriteOptions o;
      o.xyz_weights = twin::xyz_weights(table.wavelengths());
      o.comment = o.xyz_weights ? comment + "; XYZ: CIE 1964 10 deg observer, D65; Y = luminance factor"
                                : comment;
      twin::write_issa(os, table, false, o);
    } else {
      twin::TabulatedParts parts;
      parts.brdf = table;
      parts.name = scan.plan.name;
      twin::SsddWriteOptions o;
      o.comment = comment;
      o.name_entry = false;  // the scan's name as a comment: readers do not use NAME
      o.source = twin::SsddSource::measured;
      twin::write_ssdd(os, parts, o);
    }
    r.content = os.str();
  } else {
    throw Error::invalid("format", fmt::format("'{}' is not an export format (allowed: csv, json, "
                                               "bsdf, ssdd)",
                                               format));
  }
  return r;
}

ExportResult export_chunk(const Scan& scan, const std::vector<PointRecord>& points,
                          std::string_view format, std::size_t offset, bool last) {
  ExportResult r;
  r.format = std::string(format);
  r.filename = fmt::format("scan-{}.{}", scan.id, format);
  if (format == "csv") {
    r.media_type = "text/csv";
    r.content = to_csv(scan, points, offset == 0);
  } else if (format == "json") {
    r.media_type = "application/json";
    if (offset == 0) r.content = R"({"scan":)" + nlohmann::json(scan).dump() + R"(,"points":[)";
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (offset + i > 0) r.content += ',';
      r.content += nlohmann::json(points[i]).dump();
    }
    if (last) r.content += "]}";
  } else {
    throw Error::invalid("format", fmt::format("'{}' is not exported in chunks (csv, json)", format));
  }
  return r;
}

}  // namespace gonio::daemon
