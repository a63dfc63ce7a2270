// Measured data for the inverse twin: goniod's CSV and JSON exports, and tabulated BSDFs.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/point.hpp"
#include "gonio/proto/text.hpp"
#include "gonio/twin/bsdf_io.hpp"
#include "gonio/twin/fit.hpp"

namespace gonio::twin {
namespace {

constexpr std::size_t kMaxMeasuredBytes = 256u << 20;

// One CSV record: fields split at commas, with RFC 4180 double quotes.
std::vector<std::string> csv_fields(std::string_view line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') out.back() += '"', ++i;
      else if (c == '"') quoted = false;
      else out.back() += c;
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  for (auto& f : out) f = std::string(text::trim(f));
  return out;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(Errc::not_found, fmt::format("cannot open '{}'", path), "measured");
  std::string text;
  char buf[1 << 16];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) {
    text.append(buf, static_cast<std::size_t>(in.gcount()));
    if (text.size() > kMaxMeasuredBytes)
      throw Error(Errc::parse_error, fmt::format("{}: larger than {} bytes", path, kMaxMeasuredBytes),
                  "measured");
  }
  return text;
}

std::string lower_extension(const std::string& path) {
  const auto dot = path.find_last_of('.');
  const auto slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return {};
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

// Collects per-point spectra and checks that every point has the same wavelengths.
MeasuredData assemble(std::vector<MeasuredPoint> points, std::vector<std::vector<double>> nms,
                      const std::string& source) {
  if (points.empty()) throw Error(Errc::parse_error, source + ": no measured point", "measured");
  for (std::size_t k = 1; k < points.size(); ++k)
    if (nms[k] != nms[0])
      throw Error(Errc::parse_error,
                  fmt::format("{}: point {} has other wavelengths than point 1 (every point "
                              "must share one wavelength grid)", source, k + 1),
                  "measured");
  MeasuredData d;
  d.wavelengths = WavelengthGrid(nms[0], "measured.wavelength_nm");
  d.points = std::move(points);
  d.source = source;
  d.validate();
  return d;
}

}  // namespace

void MeasuredData::validate() const {
  if (wavelengths.empty()) throw Error::invalid("measured.wavelengths", "no wavelength");
  if (points.empty()) throw Error::invalid("measured.points", "no measured point");
  for (std::size_t k = 0; k < points.size(); ++k) {
    const auto& p = points[k];
    const auto field = fmt::format("measured.points[{}]", k);
    p.geometry.validate(field + ".geometry");
    if (p.beta.size() != wavelengths.size() || p.u.size() != wavelengths.size())
      throw Error::invalid(field, fmt::format("has {} values and {} uncertainties for {} "
                                              "wavelengths", p.beta.size(), p.u.size(),
                                              wavelengths.size()));
    for (std::size_t c = 0; c < p.beta.size(); ++c) {
      if (!std::isfinite(p.beta[c]))
        throw Error::invalid(fmt::format("{}.measured[{}]", field, c), "is not finite");
      if (!(p.u[c] > 0) || !std::isfinite(p.u[c]))
        throw Error::invalid(fmt::format("{}.measured_u[{}]", field, c),
                             "must be a positive finite standard uncertainty");
    }
  }
}

MeasuredData parse_measured_csv(std::string_view text, const std::string& source) {
  std::size_t line_no = 0;
  std::map<std::string, std::size_t> column;
  const char* required[] = {"theta_i", "phi_i", "theta_r", "phi_r",
                            "wavelength_nm", "measured", "measured_u"};
  std::vector<MeasuredPoint> points;
  std::vector<std::vector<double>> nms;
  std::string last_key;
  for (std::size_t pos = 0; pos < text.size();) {
    auto end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    auto line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (text::trim(line).empty() || text::trim(line).front() == '#') continue;
    const auto fields = csv_fields(line);
    const auto where = fmt::format("{}:{}", source, line_no);
    if (column.empty()) {
      for (std::size_t i = 0; i < fields.size(); ++i) column.emplace(fields[i], i);
      for (const char* name : required)
        if (!column.contains(name))
          throw Error(Errc::parse_error,
                      fmt::format("{}: the header has no '{}' column (required: theta_i, phi_i, "
                                  "theta_r, phi_r, wavelength_nm, measured, measured_u)",
                                  where, name),
                      "measured");
      continue;
    }
    const auto get = [&](const std::string& name) {
      const auto i = column.at(name);
      if (i >= fields.size() || fields[i].empty())
        throw Error(Errc::parse_error, fmt::format("{}: no value in column '{}'", where, name),
                    "measured");
      try {
        return text::parse_double(name, fields[i]);
      } catch (const Error& e) {
        throw Error(Errc::parse_error, fmt::format("{}: {}", where, e.what()), "measured");
      }
    };
    const Geometry g{get("theta_i"), get("phi_i"), get("theta_r"), get("phi_r")};
    const auto index_col = column.find("index");
    const std::string key =
        index_col != column.end() && index_col->second < fields.size()
            ? fields[index_col->second]
            : fmt::format("{}/{}/{}/{}", g.theta_i, g.phi_i, g.theta_r, g.phi_r);
    const double nm = get("wavelength_nm");
    if (points.empty() || key != last_key || (!nms.back().empty() && nm <= nms.back().back())) {
      points.push_back({g, {}, {}});
      nms.emplace_back();
      last_key = key;
    }
    nms.back().push_back(nm);
    points.back().beta.push_back(get("measured"));
    points.back().u.push_back(get("measured_u"));
  }
  if (column.empty()) throw Error(Errc::parse_error, source + ": empty file", "measured");
  try {
    return assemble(std::move(points), std::move(nms), source);
  } catch (const Error& e) {
    if (e.code() == Errc::parse_error) throw;
    throw Error(Errc::parse_error, fmt::format("{}: {}", source, e.what()), "measured");
  }
}

MeasuredData measured_from_json(const nlohmann::json& j, const std::string& source) {
  const nlohmann::json* arr = &j;
  if (j.is_object()) {
    const auto it = j.find("points");
    if (it == j.end())
      throw Error(Errc::parse_error, source + ": expected {\"points\": [...]} or an array",
                  "measured");
    arr = &*it;
  }
  if (!arr->is_array())
    throw Error(Errc::parse_error, source + ": \"points\" is not an array", "measured");
  std::vector<MeasuredPoint> points;
  std::vector<std::vector<double>> nms;
  for (std::size_t k = 0; k < arr->size(); ++k) {
    PointRecord r;
    try {
      r = (*arr)[k].get<PointRecord>();
    } catch (const Error& e) {
      throw Error(Errc::parse_error, fmt::format("{}: points[{}]: {}", source, k, e.what()),
                  "measured");
    }
    points.push_back({r.planned, r.measured.values, r.measured.std_uncertainty});
    nms.push_back(r.measured.wavelengths.values());
  }
  return assemble(std::move(points), std::move(nms), source);
}

void TableUncertainty::validate() const {
  if (!(rel > 0 && rel <= 1)) throw Error::out_of_range("table_rel_u", rel, 0, 1);
  if (!(abs >= 0 && abs <= 1)) throw Error::out_of_range("table_abs_u", abs, 0, 1);
}

MeasuredData load_measured(const std::string& path, const TableUncertainty& table_u) {
  const auto ext = lower_extension(path);
  if (ext == "csv") return parse_measured_csv(read_file(path), path);
  if (ext == "json") {
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(read_file(path));
    } catch (const nlohmann::json::parse_error& e) {
      throw Error(Errc::parse_error, fmt::format("{}: {}", path, e.what()), "measured");
    }
    return measured_from_json(j, path);
  }
  if (ext == "bsdf" || ext == "ssdd") {
    table_u.validate();
    const auto parts = ext == "bsdf" ? read_issa(path) : read_ssdd(path);
    if (!parts.brdf)
      throw Error(Errc::unsupported, path + ": the table holds no BRDF to fit", "measured");
    // Tables hold f on their own nodes, not the instrument's geometries: the points are
    // the plane of incidence at each tabulated incidence angle (p0 ≤ 85°), receiving
    // angles −85…85° every 2.5°, evaluated through the table's own interpolation where the
    // table covers them. A geometry outside it would read as f = 0, which is no measurement.
    const auto& t = *parts.brdf;
    const WavelengthGrid grid = t.wavelengths().empty()
                                    ? WavelengthGrid(std::vector<double>{555.0})
                                    : WavelengthGrid(t.wavelengths());
    std::vector<MeasuredPoint> points;
    std::vector<std::vector<double>> nms;
    std::size_t skipped = 0;
    for (const double ti : t.axis(0)) {
      if (ti < 0 || ti > 85) continue;
      for (int k = -34; k <= 34; ++k) {
        const Geometry g = Geometry::in_plane(ti, 2.5 * k);
        const auto a = g.incident_direction();
        const auto b = g.receiving_direction();
        const Vec3 wi{a[0], a[1], a[2]}, wo{b[0], b[1], b[2]};
        const auto p = t.coords(wi, wo);
        if (!t.covers(p)) {
          ++skipped;
          continue;
        }
        std::vector<double> f(t.channels());
        t.interpolate(p, f);
        MeasuredPoint m{g, {}, {}};
        for (double v : f) {
          const double beta = kPi * v;
          m.beta.push_back(beta);
          m.u.push_back(std::max(std::hypot(table_u.rel * beta, table_u.abs), 1e-12));
        }
        points.push_back(std::move(m));
        nms.push_back(grid.values());
      }
    }
    if (points.empty())
      throw Error(Errc::unsupported,
                  fmt::format("{}: the table covers none of the in-plane geometries ({} "
                              "outside its measured extent)", path, skipped),
                  "measured");
    auto data = assemble(std::move(points), std::move(nms), path);
    data.exact_directions = true;
    return data;
  }
  throw Error::invalid("measured", fmt::format("'{}': unknown extension (allowed: .csv, .json, "
                                               ".bsdf, .ssdd)", path));
}

}  // namespace gonio::twin
