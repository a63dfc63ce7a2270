#include "gonio/proto/geometry.hpp"

#include <cmath>
#include <numbers>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"
#include "gonio/proto/text.hpp"

namespace gonio {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

}  // namespace

bool Geometry::is_transmission() const noexcept { return std::abs(theta_r) > 90.0; }

std::array<double, 3> Geometry::incident_direction() const noexcept {
  const double t = theta_i * kDeg, p = phi_i * kDeg;
  return {-std::sin(t) * std::cos(p), -std::sin(t) * std::sin(p), std::cos(t)};
}

std::array<double, 3> Geometry::receiving_direction() const noexcept {
  const double t = theta_r * kDeg, p = phi_r * kDeg;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

void Geometry::validate(std::string_view field) const {
  const auto f = [field](std::string_view k) { return join_field(field, k); };
  if (!(theta_i >= 0 && theta_i <= kMaxIncidence))
    throw Error::out_of_range(f("theta_i"), theta_i, 0, kMaxIncidence, "°");
  if (!(theta_r >= -180 && theta_r <= 180))
    throw Error::out_of_range(f("theta_r"), theta_r, -180, 180, "°");
  if (std::abs(std::abs(theta_r) - 90.0) < 0.1)
    throw Error(Errc::out_of_range,
                fmt::format("{} = {:g}° is grazing (|θr| must differ from 90° by at least 0.1°)",
                            f("theta_r"), theta_r),
                f("theta_r"));
  if (!(phi_i >= -180 && phi_i <= 180))
    throw Error::out_of_range(f("phi_i"), phi_i, -180, 180, "°");
  if (!(phi_r >= -180 && phi_r <= 180))
    throw Error::out_of_range(f("phi_r"), phi_r, -180, 180, "°");
}

std::string Geometry::to_string() const {
  if (in_measurement_plane())
    return fmt::format("{}/{}", text::format_number(theta_i), text::format_number(theta_r));
  return fmt::format("{}/{} az {}/{}", text::format_number(theta_i),
                     text::format_number(theta_r), text::format_number(phi_i),
                     text::format_number(phi_r));
}

Geometry Geometry::parse(std::string_view s) {
  s = text::trim(s);
  Geometry g;
  if (const auto pos = s.find("as"); pos != std::string_view::npos) {
    g = from_aspecular(text::parse_double("geometry.theta_i", s.substr(0, pos)),
                       text::parse_double("geometry.aspecular", s.substr(pos + 2)));
  } else if (const auto slash = s.find('/'); slash != std::string_view::npos) {
    g = in_plane(text::parse_double("geometry.theta_i", s.substr(0, slash)),
                 text::parse_double("geometry.theta_r", s.substr(slash + 1)));
  } else {
    throw Error::invalid("geometry", fmt::format("'{}' is neither 'THETA_Ias ASPECULAR' (e.g. "
                                                 "45as15) nor 'THETA_I/THETA_R' (e.g. 45/30)",
                                                 s));
  }
  g.validate();
  return g;
}

const std::vector<std::pair<std::string, Geometry>>& Geometry::astm_multi_angle() {
  static const std::vector<std::pair<std::string, Geometry>> kSet = {
      {"45as-15", from_aspecular(45, -15)}, {"45as15", from_aspecular(45, 15)},
      {"45as25", from_aspecular(45, 25)},   {"45as45", from_aspecular(45, 45)},
      {"45as75", from_aspecular(45, 75)},   {"45as110", from_aspecular(45, 110)},
  };
  return kSet;
}

std::vector<Geometry> parse_geometry_grid(std::string_view text, std::size_t max_count) {
  std::vector<double> in, out, as, az_in{0}, az_out{0};
  bool have_in = false, have_out = false, have_as = false;
  for (auto part : text::split(text, ';')) {
    part = text::trim(part);
    if (part.empty()) continue;
    const auto eq = part.find('=');
    if (eq == std::string_view::npos)
      throw Error::invalid("grid", fmt::format("'{}' is not KEY=LIST", part));
    const auto key = text::trim(part.substr(0, eq));
    const auto list = part.substr(eq + 1);
    const auto field = fmt::format("grid.{}", key);
    if (key == "in") {
      in = text::parse_value_list(field, list, max_count), have_in = true;
    } else if (key == "out") {
      out = text::parse_value_list(field, list, max_count), have_out = true;
    } else if (key == "as") {
      as = text::parse_value_list(field, list, max_count), have_as = true;
    } else if (key == "az-in") {
      az_in = text::parse_value_list(field, list, max_count);
    } else if (key == "az-out") {
      az_out = text::parse_value_list(field, list, max_count);
    } else {
      throw Error::invalid("grid", fmt::format("unknown key '{}' (allowed: in, out, as, az-in, "
                                               "az-out)",
                                               key));
    }
  }
  if (!have_in) throw Error::invalid("grid.in", "missing (e.g. 'in=45;out=-80:80:2')");
  if (have_out == have_as)
    throw Error::invalid("grid.out", "give exactly one of 'out=' and 'as='");
  const auto& second = have_out ? out : as;
  const double total = static_cast<double>(in.size()) * static_cast<double>(second.size()) *
                       static_cast<double>(az_in.size()) * static_cast<double>(az_out.size());
  if (total > static_cast<double>(max_count))
    throw Error(Errc::out_of_range,
                fmt::format("grid has {:g} geometries, more than the limit {}", total, max_count),
                "grid");
  std::vector<Geometry> grid;
  grid.reserve(static_cast<std::size_t>(total));
  for (double ti : in)
    for (double pi : az_in)
      for (double v : second)
        for (double pr : az_out) {
          Geometry g{ti, pi, have_out ? v : ti - v, pr};
          g.validate(fmt::format("grid[{}]", grid.size()));
          grid.push_back(g);
        }
  return grid;
}

void to_json(nlohmann::json& j, const Geometry& g) {
  j = nlohmann::json{{"theta_i", g.theta_i}, {"phi_i", g.phi_i}, {"theta_r", g.theta_r},
                     {"phi_r", g.phi_r}};
}

void from_json(const nlohmann::json& j, Geometry& g) {
  json_util::ObjectReader r(j, "");
  g.theta_i = r.required<double>("theta_i");
  g.theta_r = r.required<double>("theta_r");
  g.phi_i = r.optional<double>("phi_i", 0.0);
  g.phi_r = r.optional<double>("phi_r", 0.0);
  r.finish();
  g.validate("");
}

}  // namespace gonio
