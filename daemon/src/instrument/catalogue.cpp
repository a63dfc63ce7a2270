// A sample's catalogue route and its uncertainty per point (see catalogue.hpp).
#include "gonio/daemon/instrument/catalogue.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio::daemon {

using nlohmann::json;

namespace {

// Linear in λ between the nodes, constant beyond the ends.
std::vector<double> on_grid(const std::vector<double>& nm, const std::vector<double>& v, const WavelengthGrid& grid) {
  std::vector<double> out;
  out.reserve(grid.size());
  for (double l : grid) {
    if (nm.size() == 1 || l <= nm.front()) {
      out.push_back(v.front());
      continue;
    }
    if (l >= nm.back()) {
      out.push_back(v.back());
      continue;
    }
    const auto hi = static_cast<std::size_t>(std::upper_bound(nm.begin(), nm.end(), l) - nm.begin());
    const double t = (l - nm[hi - 1]) / (nm[hi] - nm[hi - 1]);
    out.push_back((1 - t) * v[hi - 1] + t * v[hi]);
  }
  return out;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

std::vector<double> numbers(const json& j, const std::string& field) {
  if (!j.is_array()) throw Error::invalid(field, "must be an array of numbers");
  std::vector<double> out;
  for (std::size_t i = 0; i < j.size(); ++i) out.push_back(json_util::get_as<double>(j[i], fmt::format("{}[{}]", field, i)));
  return out;
}

const char* route_name(Catalogue::Route r) {
  return r == Catalogue::Route::master ? "master" : r == Catalogue::Route::model ? "model" : "formula";
}

// u at the master's nodes and halfway between them, and the leave-one-out figures.
json master_summary(const twin::Master& m) {
  std::vector<double> nodes, mid;
  const auto pts = m.points();
  for (std::size_t i = 0; i < pts.size(); ++i) {
    for (double u : m.at(Geometry::in_plane(pts[i].theta_i, pts[i].theta_r)).u_relative()) nodes.push_back(u);
    if (i + 1 < pts.size() && pts[i + 1].theta_i == pts[i].theta_i) {
      const auto g = Geometry::in_plane(pts[i].theta_i, (pts[i].theta_r + pts[i + 1].theta_r) / 2);
      for (double u : m.at(g).u_relative()) mid.push_back(u);
    }
  }
  const auto loo = m.leave_one_out();
  const auto stat = [](const std::vector<double>& v) {
    return json{{"median", median(v)}, {"max", v.empty() ? 0.0 : *std::max_element(v.begin(), v.end())}};
  };
  return json{{"points", pts.size()},
              {"incidences", m.incidences()},
              {"u_relative_at_nodes", stat(nodes)},
              {"u_relative_mid_interval", stat(mid)},
              {"leave_one_out", {{"residuals", loo.residuals},
                                 {"within_1u", loo.fraction(1)},
                                 {"within_2u", loo.fraction(2)},
                                 {"rms_z", loo.rms_z}}}};
}

}  // namespace

json to_json(const twin::MasterPoint& p) {
  return json{{"theta_i", p.theta_i}, {"theta_r", p.theta_r}, {"beta", p.beta}, {"u", p.u}};
}

twin::MasterPoint master_point_from_json(const json& j, const std::string& field) {
  json_util::ObjectReader r(j, field);
  twin::MasterPoint p;
  p.theta_i = r.required<double>("theta_i");
  p.theta_r = r.required<double>("theta_r");
  p.beta = numbers(r.raw("beta") ? *r.raw("beta") : json(), r.path("beta"));
  p.u = numbers(r.raw("u") ? *r.raw("u") : json(), r.path("u"));
  r.finish();
  return p;
}

Catalogue Catalogue::of(const Sample& sample) {
  Catalogue c;
  c.model_u_ = sample.spec.model_u;
  if (sample.catalogue.empty()) return c;
  try {
    const json j = json::parse(sample.catalogue);
    const auto route = j.at("route").get<std::string>();
    if (j.at("master_scan").is_number_integer()) c.scan_ = j.at("master_scan").get<std::int64_t>();
    c.extra_ = j;
    c.extra_.erase("points");
    if (route == "master") {
      c.route_ = Route::master;
      std::vector<twin::MasterPoint> pts;
      for (const auto& p : j.at("points")) pts.push_back(master_point_from_json(p, "points"));
      c.master_.emplace(numbers(j.at("wavelengths"), "wavelengths"), std::move(pts));
    } else if (route == "model") {
      c.route_ = Route::model;
      c.spec_ = j.at("model").get<std::string>();
      for (const auto& b : j.at("summary").at("misfit"))
        c.bins_.push_back(MisfitBin{b.at("aspecular_deg")[0].get<double>(), b.at("aspecular_deg")[1].get<double>(),
                                    b.at("points").get<std::size_t>(), b.at("rms_relative").get<double>(),
                                    b.at("noise_relative").get<double>(), b.at("u").get<double>()});
    } else {
      throw Error::invalid("route", route);
    }
  } catch (const std::exception& e) {
    throw Error(Errc::internal, fmt::format("sample {}: its stored catalogue cannot be read: {}", sample.id, e.what()));
  }
  return c;
}

Catalogue Catalogue::master(std::optional<std::int64_t> scan, twin::Master corrected, json correction) {
  Catalogue c;
  c.route_ = Route::master;
  c.scan_ = scan;
  c.extra_ = json{{"route", "master"},
                  {"master_scan", scan ? json(*scan) : json(nullptr)},
                  {"correction", std::move(correction)},
                  {"summary", master_summary(corrected)},
                  {"wavelengths", corrected.wavelengths()}};
  c.master_ = std::move(corrected);
  return c;
}

Catalogue Catalogue::model(std::int64_t scan, std::string spec, std::vector<MisfitBin> bins, json fit) {
  Catalogue c;
  c.route_ = Route::model;
  c.scan_ = scan;
  c.spec_ = std::move(spec);
  c.bins_ = std::move(bins);
  json misfit = json::array();
  double worst = 0;
  for (const auto& b : c.bins_) {
    misfit.push_back(json{{"aspecular_deg", {b.lo, b.hi}}, {"points", b.points}, {"rms_relative", b.rms_relative},
                          {"noise_relative", b.noise_relative}, {"u", b.u}});
    worst = std::max(worst, b.u);
  }
  c.extra_ = json{{"route", "model"},
                  {"master_scan", scan},
                  {"model", c.spec_},
                  {"summary", {{"misfit", std::move(misfit)}, {"u_relative_max", worst}}},
                  {"fit", std::move(fit)}};
  return c;
}

bool Catalogue::has_u() const noexcept {
  return route_ == Route::master || (route_ == Route::model && !bins_.empty()) || model_u_ > 0;
}

std::string Catalogue::uncovered(const Geometry& g) const {
  return master_ ? master_->uncovered(g) : std::string();
}

std::vector<double> Catalogue::relative_u(const Geometry& g, const WavelengthGrid& grid) const {
  switch (route_) {
    case Route::master:
      return on_grid(master_->wavelengths(), master_->at(g).u_relative(), grid);
    case Route::model: {
      // Beyond the master's range the model extrapolates: the largest misfit found.
      const double x = std::abs(g.aspecular());
      double u = 0, worst = 0;
      bool found = false;
      for (const auto& b : bins_) {
        worst = std::max(worst, b.u);
        if (x >= b.lo && x < b.hi) u = b.u, found = true;
      }
      if (!found) u = worst;
      return u > 0 ? std::vector<double>(grid.size(), u) : std::vector<double>{};
    }
    case Route::formula:
      break;
  }
  return model_u_ > 0 ? std::vector<double>(grid.size(), model_u_) : std::vector<double>{};
}

std::string Catalogue::stored() const {
  if (route_ == Route::formula) return {};
  json j = extra_;
  j["route"] = route_name(route_);
  if (master_) {
    json pts = json::array();
    for (const auto& p : master_->points()) pts.push_back(to_json(p));
    j["points"] = std::move(pts);
  }
  return j.dump();
}

void add_catalogue_entry(twin::Budget& budget, const std::vector<double>& beta, const std::vector<double>& u) {
  if (u.empty() || std::all_of(u.begin(), u.end(), [](double v) { return v == 0; })) return;
  twin::BudgetComponent c;
  c.name = "catalogue";
  c.unit = "1";
  c.distribution = twin::Distribution::normal;
  c.random = true;
  c.u = u;
  c.sensitivity = beta;
  c.contribution.resize(u.size());
  for (std::size_t k = 0; k < u.size(); ++k) c.contribution[k] = u[k] * std::abs(k < beta.size() ? beta[k] : 0);
  const auto grow = [&](std::vector<double>& v) {
    if (v.size() < u.size()) v.resize(u.size(), 0);
    for (std::size_t k = 0; k < u.size(); ++k) v[k] = std::hypot(v[k], c.contribution[k]);
  };
  grow(budget.u_model);
  grow(budget.u_random);
  budget.components.push_back(std::move(c));
}

}  // namespace gonio::daemon
