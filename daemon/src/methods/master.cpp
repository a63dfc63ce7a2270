// Catalogues from master references (see master.hpp).
//
// The instrument correction of a master is one multiplicative step of van Cittert's
// iteration (Gold's ratio form): the measured curve m, made into a table, is measured again
// by the twin, p = twin(table(m)), and the catalogue keeps β = m·(m/p). A scan is the
// instrument's convolution of the true BSDF; one step removes the aperture's blur to first
// order and keeps β positive, and the twin of the corrected table reproduces the master's
// own readings (twin(table(β)) ≈ m) at its geometries. Further steps would sharpen the
// measurement noise along with the lobe (deconvolution is ill-posed), so there is one. It is
// the ratio the inverse twin's `correct` applies (true/virtual of a fitted model), with the
// measurement as its own model: no formula is assumed of a sample whose point is that none
// describes it. The factor's u is the twin's Monte Carlo error; the master's own noise enters
// m/p almost equally above and below and is kept as the measured u.
#include "methods/master.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "gonio/twin/bsdf_io.hpp"
#include "gonio/twin/budget.hpp"
#include "gonio/twin/fit.hpp"
#include "methods/inverse.hpp"
#include "methods/params.hpp"

namespace gonio::daemon::methods {

using json_util::ObjectReader;
using nlohmann::json;

namespace {

// Aspecular regions of a model's misfit, degrees of |θi − θr|.
constexpr double kMisfitEdges[] = {0, 3, 10, 25, 50, 180};

Scan completed_scan(const Store& store, std::int64_t id) {
  const auto found = store.scan(id);
  if (!found) throw Error::not_found("reference.scan", fmt::format("scan {}", id));
  const auto& scan = *found;
  if (scan.state != ScanState::completed)
    throw Error::wrong_state("reference.scan", fmt::format("scan {} is {}; a master is made from a completed scan",
                                                           id, to_text(scan.state)));
  return *found;
}

twin::Master master_of_scan(const Store& store, const Scan& scan) {
  std::vector<twin::MasterPoint> pts;
  for (const auto& p : store.points(scan.id, 0, scan.points_done + 1)) {
    if (!p.planned.in_measurement_plane())
      throw Error::invalid("reference.scan", fmt::format("scan {} point {} ({}) is out of the plane of measurement; "
                                                         "a master is measured in it",
                                                         scan.id, p.index, p.planned.to_string()));
    pts.push_back({p.planned.theta_i, p.planned.theta_r, p.measured.values, p.measured.std_uncertainty});
  }
  try {
    return twin::Master(scan.plan.wavelengths.values(), std::move(pts), "reference.scan");
  } catch (const Error& e) {
    std::string why = e.what();
    if (why.starts_with(e.field() + ": ")) why.erase(0, e.field().size() + 2);
    throw Error(e.code(), fmt::format("reference.scan: scan {}: {}", scan.id, why), "reference.scan");
  }
}

std::vector<Geometry> geometries_of(const twin::Master& m) {
  std::vector<Geometry> out;
  for (const auto& p : m.points()) out.push_back(Geometry::in_plane(p.theta_i, p.theta_r));
  return out;
}

// The master's table measured by the twin at the master's own geometries, and what the
// instrument's random inputs (arm repeatability, lamp) did to each of the master's readings:
// the master is one draw of them, which its photometer u does not hold.
struct Remeasured {
  std::vector<twin::Prediction> pred;
  std::vector<std::vector<double>> u_random;
};

Remeasured remeasured(Services& s, const twin::Master& m) {
  const WavelengthGrid grid(m.wavelengths());
  twin::TabulatedParts parts;
  parts.brdf = m.table();
  auto bsdf = std::make_shared<const twin::TabulatedBsdf>(grid, std::move(parts), "master");
  const twin::Twin tw(s.twin.profile(), bsdf, grid);
  Remeasured out{s.twin.predict(tw, geometries_of(m), s.twin.options()), {}};
  const twin::BudgetModel budget(tw);
  for (const auto& p : out.pred) out.u_random.push_back(budget.evaluate(p, s.twin.options()).u_random);
  return out;
}

// One van Cittert step (above): β = m·m/p with u = (m/p)·√(u_m² + u_random² + (m·s_p/p)²).
std::pair<twin::Master, json> corrected(Services& s, const twin::Master& m) {
  const auto [pred, u_random] = remeasured(s, m);
  const auto pts = m.points();
  std::vector<std::vector<double>> beta, u;
  double lo = 1e300, hi = 0;
  for (std::size_t j = 0; j < pts.size(); ++j) {
    std::vector<double> b(m.channels()), uu(m.channels());
    for (std::size_t k = 0; k < m.channels(); ++k) {
      const double mk = pts[j].beta[k], pk = pred[j].beta[k];
      const double f = pk > 0 && mk > 0 ? mk / pk : 1.0;
      lo = std::min(lo, f), hi = std::max(hi, f);
      b[k] = mk * f;
      const double ur = k < u_random[j].size() ? u_random[j][k] : 0.0;
      uu[k] = f * std::hypot(pts[j].u[k], ur, pk > 0 ? mk * pred[j].std_error[k] / pk : 0.0);
    }
    beta.push_back(std::move(b));
    u.push_back(std::move(uu));
  }
  json info{{"method", "van_cittert"}, {"steps", 1}, {"factor_min", lo}, {"factor_max", hi},
            {"profile", s.twin.profile().name}};
  return {m.with_values(std::move(beta), std::move(u)), std::move(info)};
}

// <state>/masters/<name>.ssdd, spectral, specular; `written` when this call created it.
std::string write_table(Services& s, const twin::Master& m, const std::string& name, bool& written) {
  namespace fs = std::filesystem;
  const fs::path dir = s.state_dir / "masters";
  std::error_code ec;
  fs::create_directories(dir, ec);
  const fs::path path = dir / (name + ".ssdd");
  if (s.store.sample_by_name(name)) throw Error::exists("name", fmt::format("a sample named '{}'", name));
  written = !fs::exists(path);
  twin::TabulatedParts parts;
  parts.brdf = m.table();
  parts.name = fmt::format("master of sample {}", name);
  twin::SsddWriteOptions o;
  o.source = twin::SsddSource::measured;
  const fs::path tmp = path.string() + ".tmp";
  twin::write_ssdd(tmp.string(), parts, o);
  fs::rename(tmp, path, ec);
  if (ec) throw Error(Errc::io_error, fmt::format("cannot write the master's table {}: {}", path.string(), ec.message()));
  return "@" + path.string();
}

// The model's misfit per aspecular region: what the noise does not explain.
std::vector<MisfitBin> misfit_bins(Services& s, const twin::Master& m, const std::string& spec) {
  const WavelengthGrid grid(m.wavelengths());
  const auto tw = s.twin.make(spec, grid, "reference.model");
  const auto pred = s.twin.predict(*tw, geometries_of(m), s.twin.options());
  const auto pts = m.points();
  std::vector<MisfitBin> bins;
  for (std::size_t b = 0; b + 1 < std::size(kMisfitEdges); ++b) {
    MisfitBin bin{kMisfitEdges[b], kMisfitEdges[b + 1], 0, 0, 0, 0};
    double r2 = 0, n2 = 0, count = 0;
    for (std::size_t j = 0; j < pts.size(); ++j) {
      const double x = std::abs(pts[j].theta_i - pts[j].theta_r);
      if (x < bin.lo || x >= bin.hi) continue;
      ++bin.points;
      for (std::size_t k = 0; k < m.channels(); ++k) {
        const double p = pred[j].beta[k], mk = pts[j].beta[k];
        if (!(p > 0)) continue;
        r2 += std::pow((mk - p) / p, 2);
        n2 += std::pow(pts[j].u[k] / p, 2) + std::pow(pred[j].std_error[k] / p, 2);
        ++count;
      }
    }
    if (count == 0) continue;
    bin.rms_relative = std::sqrt(r2 / count);
    bin.noise_relative = std::sqrt(n2 / count);
    bin.u = std::sqrt(std::max(0.0, (r2 - n2) / count));
    bins.push_back(bin);
  }
  return bins;
}

MadeCatalogue from_model(Services& s, const Scan& scan, const twin::Master& m, const std::string& model) {
  auto data = measured_of_scan(s.store, scan.id);
  twin::FitOptions o;
  o.replicates = s.twin.options().replicates;
  o.seed = s.twin.options().seed;
  o.threads = s.twin.threads();
  const auto r = with_field("reference.model",
                            [&] { return twin::fit_material(data, model, s.twin.profile(), o); });
  if (!r.converged)
    throw Error::invalid("reference.model", fmt::format("the fit of '{}' to scan {} did not converge ({}); give "
                                                        "starting values or fewer free parameters",
                                                        model, scan.id, r.status));
  json fit = r.to_json();
  json kept = json::object();
  for (const char* k : {"parameters", "chi2_per_dof", "dof", "converged", "status", "spec"})
    if (fit.contains(k)) kept[k] = fit[k];
  return {r.spec, Catalogue::model(scan.id, r.spec, misfit_bins(s, m, r.spec), std::move(kept))};
}

// A master exported by another goniod (master_document), or a tabulated BSDF file taken as
// the true BSDF (in-plane points where it covers, with the inverse twin's table u).
twin::Master master_of_file(Services& s, const std::string& file, json& source) {
  const auto spec = confine_bsdf_files("@" + file, s.data_dir, "reference.file");
  const std::string path = spec.substr(1);
  source = json{{"file", file}};
  if (path.ends_with(".json")) {
    std::ifstream in(path);
    const json doc = json::parse(in, nullptr, false);
    if (!doc.is_object() || doc.value("format", "") != "gonio-master")
      throw Error(Errc::parse_error, fmt::format("'{}' is not a master document (format \"gonio-master\")", file),
                  "reference.file");
    std::vector<twin::MasterPoint> pts;
    const auto& arr = doc.contains("points") ? doc["points"] : json::array();
    for (std::size_t i = 0; i < arr.size(); ++i)
      pts.push_back(master_point_from_json(arr[i], fmt::format("reference.file.points[{}]", i)));
    std::vector<double> nm;
    const auto wl = doc.value("wavelengths", json::array());
    for (std::size_t i = 0; i < wl.size(); ++i)
      nm.push_back(json_util::get_as<double>(wl[i], fmt::format("reference.file.wavelengths[{}]", i)));
    source["from"] = {{"sample", doc.value("sample", "")}, {"master_scan", doc.value("master_scan", json(nullptr))}};
    return twin::Master(std::move(nm), std::move(pts), "reference.file.points");
  }
  const auto data = with_field("reference.file", [&] { return twin::load_measured(path); });
  std::vector<twin::MasterPoint> pts;
  for (const auto& p : data.points)
    if (p.geometry.in_measurement_plane()) pts.push_back({p.geometry.theta_i, p.geometry.theta_r, p.beta, p.u});
  return twin::Master(data.wavelengths.values(), std::move(pts), "reference.file");
}

}  // namespace

MadeCatalogue make_catalogue(Services& s, const json& reference, const std::string& name, bool& written) {
  ObjectReader r(reference, "reference");
  const auto* file = r.raw("file");
  std::optional<std::int64_t> scan_id;
  if (!file) scan_id = read_id(r, "scan");
  const auto model = r.optional<std::string>("model", "");
  r.finish();
  if (file) {
    if (model.size()) throw Error::invalid("reference.model", "a model is fitted to a scan, not to a file");
    json source;
    const auto m = master_of_file(s, json_util::get_as<std::string>(*file, "reference.file"), source);
    auto c = Catalogue::master(std::nullopt, m, json{{"method", "none"}, {"source", source}});
    return {write_table(s, m, name, written), std::move(c)};
  }
  const auto scan = completed_scan(s.store, *scan_id);
  const auto measured = master_of_scan(s.store, scan);
  if (!model.empty())
    return from_model(s, scan, measured, confine_bsdf_files(model, s.data_dir, "reference.model"));
  auto [m, info] = corrected(s, measured);
  auto c = Catalogue::master(scan.id, m, std::move(info));
  return {write_table(s, m, name, written), std::move(c)};
}

json master_document(const Sample& sample, const Catalogue& c) {
  const auto* m = c.master_data();
  if (!m)
    throw Error::wrong_state("sample", fmt::format("sample '{}' is not made from a master (route {})", sample.spec.name,
                                                   c.route() == Catalogue::Route::model ? "model" : "formula"));
  json pts = json::array();
  for (const auto& p : m->points()) pts.push_back(to_json(p));
  return json{{"format", "gonio-master"},
              {"version", 1},
              {"sample", sample.spec.name},
              {"master_scan", c.master_scan() ? json(*c.master_scan()) : json(nullptr)},
              {"tolerance", sample.spec.tolerance},
              {"wavelengths", m->wavelengths()},
              {"points", std::move(pts)}};
}

}  // namespace gonio::daemon::methods
