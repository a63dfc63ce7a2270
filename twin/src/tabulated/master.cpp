// Master references: curves over the aspecular angle, their interpolation and its
// uncertainty, and the table the twin predicts from (see master.hpp).
#include "gonio/twin/master.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"

namespace gonio::twin {
namespace {

constexpr double kSameX = 1e-6;  // degrees: one geometry

// Second divided difference of channel k over nodes i < j < l.
double second_difference(const std::vector<double>& x, const std::vector<std::vector<double>>& b,
                         std::size_t i, std::size_t j, std::size_t l, std::size_t k) {
  const double s1 = (b[j][k] - b[i][k]) / (x[j] - x[i]);
  const double s2 = (b[l][k] - b[j][k]) / (x[l] - x[j]);
  return 2 * (s2 - s1) / (x[l] - x[i]);
}

std::string list_deg(const std::vector<double>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + text::format_number(v[i]) + "°";
  return s;
}

}  // namespace

std::vector<double> MasterEstimate::u_relative() const {
  std::vector<double> out(beta.size());
  for (std::size_t k = 0; k < beta.size(); ++k)
    out[k] = beta[k] > 0 ? std::hypot(u_measured[k], u_interpolation[k]) / beta[k] : 0;
  return out;
}

double LooReport::fraction(double k) const {
  if (residuals == 0) return 0;
  return static_cast<double>(k >= 2 ? within_2u : within_1u) / static_cast<double>(residuals);
}

Master::Master(std::vector<double> nm, std::vector<MasterPoint> points, const std::string& field)
    : nm_(std::move(nm)) {
  if (nm_.empty()) throw Error::invalid(field, "a master needs at least one wavelength");
  // Group by incidence (within kIncidenceMatch) and merge repeats of one geometry.
  struct Acc {
    std::vector<double> sum, u2;
    int n = 0;
  };
  std::map<long, std::map<long, Acc>> by;  // incidence and x in 1/1000 degree
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto& p = points[i];
    const auto f = fmt::format("{}[{}]", field, i);
    const Geometry g = Geometry::in_plane(p.theta_i, p.theta_r);
    if (!(std::isfinite(p.theta_i) && std::isfinite(p.theta_r)) || p.theta_i < 0 || p.theta_i >= 90 ||
        std::abs(p.theta_r) >= 90 || g.is_transmission())
      throw Error::invalid(f, fmt::format("{}/{} is not an in-plane reflection geometry",
                                          text::format_number(p.theta_i), text::format_number(p.theta_r)));
    if (p.beta.size() != nm_.size() || p.u.size() != nm_.size())
      throw Error::invalid(f + ".beta", fmt::format("has {} values (and {} u) for {} wavelengths",
                                                    p.beta.size(), p.u.size(), nm_.size()));
    for (std::size_t k = 0; k < nm_.size(); ++k)
      if (!(std::isfinite(p.beta[k]) && p.beta[k] >= 0 && std::isfinite(p.u[k]) && p.u[k] >= 0))
        throw Error::invalid(fmt::format("{}.beta[{}]", f, k),
                             "β and its u must be finite and >= 0");
    auto& a = by[std::lround(p.theta_i * 1000)][std::lround((p.theta_i - p.theta_r) * 1000)];
    if (a.sum.empty()) a.sum.assign(nm_.size(), 0), a.u2.assign(nm_.size(), 0);
    for (std::size_t k = 0; k < nm_.size(); ++k) a.sum[k] += p.beta[k], a.u2[k] += p.u[k] * p.u[k];
    ++a.n;
  }
  for (const auto& [ti, xs] : by) {
    const double theta_i = static_cast<double>(ti) / 1000;
    if (!curves_.empty() && theta_i - curves_.back().theta_i < kIncidenceMatch)
      throw Error::invalid(field, fmt::format("incidence angles {}° and {}° are too close to tell apart",
                                              text::format_number(curves_.back().theta_i),
                                              text::format_number(theta_i)));
    if (xs.size() < kMinNodes)
      throw Error::invalid(field, fmt::format("the curve at θi = {}° has {} geometries; a master needs at "
                                              "least {} per incidence angle",
                                              text::format_number(theta_i), xs.size(), kMinNodes));
    Curve c;
    c.theta_i = theta_i;
    for (const auto& [x, a] : xs) {
      c.x.push_back(static_cast<double>(x) / 1000);
      std::vector<double> b(nm_.size()), u(nm_.size());
      for (std::size_t k = 0; k < nm_.size(); ++k) b[k] = a.sum[k] / a.n, u[k] = std::sqrt(a.u2[k]) / a.n;
      c.beta.push_back(std::move(b));
      c.u.push_back(std::move(u));
    }
    curves_.push_back(std::move(c));
  }
  if (curves_.empty()) throw Error::invalid(field, "a master needs measured points");
}

std::vector<MasterPoint> Master::points() const {
  std::vector<MasterPoint> out;
  for (const auto& c : curves_)
    for (std::size_t j = 0; j < c.x.size(); ++j) out.push_back({c.theta_i, c.theta_i - c.x[j], c.beta[j], c.u[j]});
  return out;
}

std::vector<double> Master::incidences() const {
  std::vector<double> out;
  for (const auto& c : curves_) out.push_back(c.theta_i);
  return out;
}

const Master::Curve* Master::curve_at(double theta_i) const noexcept {
  for (const auto& c : curves_)
    if (std::abs(c.theta_i - theta_i) <= kIncidenceMatch) return &c;
  return nullptr;
}

std::string Master::uncovered(const Geometry& g) const {
  if (!g.in_measurement_plane() || g.is_transmission())
    return "the master was measured in the plane of measurement, in reflection";
  const Curve* c = curve_at(g.theta_i);
  if (!c)
    return fmt::format("θi = {}° is not an incidence angle of the master ({}); it does not "
                       "interpolate across incidence angles",
                       text::format_number(g.theta_i), list_deg(incidences()));
  const double x = g.aspecular();
  if (x < c->x.front() - kSameX || x > c->x.back() + kSameX)
    return fmt::format("θr = {}° (aspecular {}°) lies outside the master's receiving range at θi = {}° "
                       "(θr {}° to {}°)",
                       text::format_number(g.theta_r), text::format_number(x), text::format_number(c->theta_i),
                       text::format_number(c->theta_i - c->x.back()), text::format_number(c->theta_i - c->x.front()));
  return {};
}

MasterEstimate Master::at(const Geometry& g) const {
  if (auto why = uncovered(g); !why.empty())
    throw Error(Errc::out_of_range, fmt::format("geometry {}: {}", g.to_string(), why), "geometry");
  const Curve& c = *curve_at(g.theta_i);
  return estimate(c, std::clamp(g.aspecular(), c.x.front(), c.x.back()), c.x.size());
}

MasterEstimate Master::estimate(const Curve& c, double x, std::size_t skip) const {
  // The nodes in use, without `skip`.
  std::vector<std::size_t> n;
  for (std::size_t j = 0; j < c.x.size(); ++j)
    if (j != skip) n.push_back(j);
  const std::size_t C = nm_.size();
  MasterEstimate e{std::vector<double>(C), std::vector<double>(C), std::vector<double>(C, 0.0)};
  std::size_t i = 0;
  while (i + 2 < n.size() && c.x[n[i + 1]] < x) ++i;  // interval [n[i], n[i+1]] holds x
  const std::size_t a = n[i], b = n[i + 1];
  if (std::abs(x - c.x[a]) < kSameX || std::abs(x - c.x[b]) < kSameX) {
    const std::size_t j = std::abs(x - c.x[a]) < kSameX ? a : b;
    e.beta = c.beta[j];
    e.u_measured = c.u[j];
    return e;
  }
  const double t = (x - c.x[a]) / (c.x[b] - c.x[a]);
  const double w = (x - c.x[a]) * (c.x[b] - x) / 2;
  for (std::size_t k = 0; k < C; ++k) {
    e.beta[k] = (1 - t) * c.beta[a][k] + t * c.beta[b][k];
    e.u_measured[k] = std::hypot((1 - t) * c.u[a][k], t * c.u[b][k]);
    double d2 = 0;
    if (i > 0) d2 = std::max(d2, std::abs(second_difference(c.x, c.beta, n[i - 1], a, b, k)));
    if (i + 2 < n.size()) d2 = std::max(d2, std::abs(second_difference(c.x, c.beta, a, b, n[i + 2], k)));
    e.u_interpolation[k] = w * d2;
  }
  return e;
}

LooReport Master::leave_one_out() const {
  LooReport r;
  double z2 = 0;
  for (const auto& c : curves_)
    for (std::size_t j = 1; j + 1 < c.x.size(); ++j) {
      const auto e = estimate(c, c.x[j], j);
      for (std::size_t k = 0; k < nm_.size(); ++k) {
        const double u = std::sqrt(e.u_measured[k] * e.u_measured[k] +
                                   e.u_interpolation[k] * e.u_interpolation[k] + c.u[j][k] * c.u[j][k]);
        const double d = std::abs(c.beta[j][k] - e.beta[k]);
        ++r.residuals;
        if (d <= u) ++r.within_1u;
        if (d <= 2 * u) ++r.within_2u;
        z2 += u > 0 ? (d / u) * (d / u) : (d > 0 ? 1e6 : 0);
      }
    }
  r.rms_z = r.residuals ? std::sqrt(z2 / static_cast<double>(r.residuals)) : 0;
  return r;
}

Master Master::with_values(std::vector<std::vector<double>> beta, std::vector<std::vector<double>> u) const {
  auto pts = points();
  if (beta.size() != pts.size() || u.size() != pts.size())
    throw Error(Errc::internal, "master values do not match its points");
  for (std::size_t i = 0; i < pts.size(); ++i) pts[i].beta = std::move(beta[i]), pts[i].u = std::move(u[i]);
  return Master(nm_, std::move(pts));
}

std::vector<double> Master::clamped(const Curve& c, double x) const {
  x = std::clamp(x, c.x.front(), c.x.back());
  return estimate(c, x, c.x.size()).beta;
}

BsdfTable Master::table() const {
  std::vector<double> theta, radial{0};
  for (const auto& c : curves_) {
    theta.push_back(c.theta_i);
    for (double x : c.x) radial.push_back(std::abs(x));
  }
  std::sort(radial.begin(), radial.end());
  radial.erase(std::unique(radial.begin(), radial.end(), [](double a, double b) { return b - a < 1e-3; }),
               radial.end());
  const std::vector<double> azimuth{0, 180};
  const std::size_t C = nm_.size(), n0 = theta.size(), n2 = radial.size();
  std::vector<double> values(n0 * n2 * azimuth.size() * C);
  for (std::size_t a = 0; a < azimuth.size(); ++a)
    for (std::size_t j = 0; j < n2; ++j)
      for (std::size_t i = 0; i < n0; ++i) {
        // azimuth 0 points from the specular direction toward the normal: θr < θi, x > 0
        const double x = a == 0 ? radial[j] : -radial[j];
        const auto b = clamped(curves_[i], x);
        for (std::size_t k = 0; k < C; ++k)
          values[(((a * n2 + j) * 1 + 0) * n0 + i) * C + k] = b[k] / std::numbers::pi;
      }
  return BsdfTable(TableParam::specular, BsdfTable::Axes{theta, {}, radial, azimuth}, nm_, std::move(values),
                   TableReduction{true, false});
}

}  // namespace gonio::twin
