// Scan export to CSV, JSON, IS-SA and SSDD (see export.hpp).
#include "gonio/daemon/store/export.hpp"

#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/twin/bsdf_io.hpp"
#include "gonio/twin/color.hpp"
#include "gonio/twin/in_plane.hpp"
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

// The measured BRDF on an isotropic spherical grid; the nodes the scan did not measure (the
// arms' collision zone, or any direction left out) hold 0, the mark of a direction not
// measured that the twin's readers know (BsdfTable::covers). Neither format has another:
// the IS-SA specification (Rykowski, "BSDF Data Interchange File Format Specification",
// 2008) and SSDD 0.3 (libbsdf doc/SsddFileFormatSpecification.md) both define the data as
// BSDF values, non-negative numbers, with no reserved value — and IS-SA files from
// instruments write 0 where they measured nothing (below the horizon). The header names
// the gaps in comment lines, which both formats allow ('#').
twin::InPlaneTable to_table(const Scan& scan, const std::vector<PointRecord>& points) {
  if (points.empty()) throw Error(Errc::unsupported, "the scan has no measured point to export");
  std::vector<twin::InPlaneReading> readings;
  readings.reserve(points.size());
  for (const auto& p : points) readings.push_back({p.planned, p.measured.values, p.index});
  return twin::in_plane_table_with_gaps(readings, scan.plan.wavelengths.values(),
                                        {.what = "the scan", .remedy = "export csv or json", .field = {}});
}

std::string gap_comment(const twin::InPlaneTable& t) {
  if (t.gaps.empty()) return {};
  std::string s = fmt::format("\nnot measured ({} nodes, written as 0 in every channel):", t.gaps.size());
  for (const auto& r : t.gap_ranges()) s += "\n  " + r;
  return s;
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
    const auto measured = to_table(scan, points);
    const auto& table = measured.table;
    std::ostringstream os;
    const auto comment = fmt::format("gonio scan {} (sample {}), measured BRDF f = beta/pi",
                                     scan.id, scan.plan.sample_id);
    if (format == "bsdf") {
      // A spectral scan keeps its colour: IS-SA XYZ blocks (D65, 10° observer, Y = the
      // luminance factor), as gonio-twin convert writes them; a single channel is Monochrome.
      twin::IssaWriteOptions o;
      o.keep_gaps = true;
      o.xyz_weights = twin::xyz_weights(table.wavelengths());
      o.comment = o.xyz_weights ? comment + "; XYZ: CIE 1964 10 deg observer, D65; Y = luminance factor"
                                : comment;
      o.comment += gap_comment(measured);
      if (!measured.gaps.empty())
        o.comment += "\nTIS counts the directions not measured as 0";
      twin::write_issa(os, table, false, o);
    } else {
      twin::TabulatedParts parts;
      parts.brdf = table;
      parts.name = scan.plan.name;
      twin::SsddWriteOptions o;
      o.comment = comment + gap_comment(measured);
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
