// The scan's verdict and alerts as gonioctl prints them (see ctl_internal.hpp): what
// `scan get`, `scan watch`, `scan submit --watch` and `demo` end with.
#include <iostream>

#include <fmt/format.h>

#include "ctl/ctl_internal.hpp"
#include "gonio/daemon/ctl/ctl.hpp"
#include "gonio/proto/text.hpp"

namespace gonio::daemon::ctl {

using nlohmann::json;

namespace {

double number(const json& j, const char* key) {
  const auto it = j.find(key);
  return it != j.end() && it->is_number() ? it->get<double>() : 0.0;
}

// "lambert.albedo = 0.200 ± 0.012 (catalogued 0.5)", "catalogue 400–590 nm scaled by
// 0.345 ± 0.014 (catalogued 1)": the value rounded to its u (GUM §7.2.6).
std::string cause_text(const json& c) {
  const auto parameter = c.value("parameter", std::string());
  const auto value = text::format_measured(number(c, "value"), number(c, "u"));
  const auto nominal = fmt::format("{:.4g}", number(c, "nominal"));
  const bool sample = c.value("kind", std::string()) == "sample";
  if (c.contains("band_nm") && c["band_nm"].is_array() && c["band_nm"].size() == 2)
    return fmt::format("{} {:g}–{:g} nm scaled by {} ({} {})", parameter.substr(0, parameter.rfind('@')),
                       c["band_nm"][0].get<double>(), c["band_nm"][1].get<double>(), value,
                       sample ? "catalogued" : "nominal", nominal);
  return fmt::format("{} = {} ({} {})", parameter, value, sample ? "catalogued" : "nominal", nominal);
}

}  // namespace

std::string verdict_text(const json& v) {
  if (!v.is_object() || !v.contains("decision"))
    return "verdict: none yet (no point with a prediction)\n";
  std::string out = fmt::format("verdict: {} over {} points", v.value("decision", std::string()),
                                cell(v.value("points_used", json(0))));
  const auto& alike = v.contains("alike") && v["alike"].is_array() ? v["alike"] : json::array();
  if (v.contains("cause") && v["cause"].is_object()) {
    out += " — cause: " + cause_text(v["cause"]);
  } else if (!alike.empty()) {
    std::string names;
    for (const auto& a : alike) names += (names.empty() ? "" : " or ") + cause_text(a);
    out += " — cause undetermined: " + names;
  } else if (!v.value("explained", true)) {
    out += fmt::format(" — unexplained: no single cause fits (χ²/dof {:.3g})", number(v, "chi2_per_dof"));
  } else {
    out += " — no cause named";
  }
  out += "\n";
  if (v.contains("calibration_hint") && v["calibration_hint"].is_object())
    out += "  calibration hint: " + cause_text(v["calibration_hint"]) + "\n";
  if (!v.value("explained", true) && v.contains("regions") && !v["regions"].empty()) {
    out += "  worst regions:";
    for (const auto& r : v["regions"])
      out += fmt::format(" θi {:g}°, aspecular {:g}…{:g}°: {} % ({} points, {});", number(r, "theta_i"),
                         r["aspecular"][0].get<double>(), r["aspecular"][1].get<double>(),
                         text::format_measured(100 * number(r, "mean_rel"), 100 * number(r, "u")),
                         cell(r["points"]), r.value("decision", std::string()));
    out.back() = '\n';
  }
  if (const auto summary = v.value("summary", std::string()); !summary.empty()) out += "  why: " + summary + "\n";
  return out;
}

ScanAlerts scan_alerts(Session& s, std::int64_t scan) {
  ScanAlerts a;
  a.list = s.call("alert.list", json{{"scan", scan}, {"limit", 1000}});
  for (const auto& x : a.list) {
    if (!x.value("resolved_at", json()).is_null()) {
      ++a.resolved;
      continue;
    }
    ++a.standing;
    a.critical += x.value("severity", std::string()) == "critical";
  }
  return a;
}

std::string alerts_text(const ScanAlerts& a, std::int64_t scan) {
  if (a.standing + a.resolved == 0) return "alerts: none\n";
  return fmt::format("alerts: {} standing ({} critical), {} resolved — gonioctl alert list --scan {}\n",
                     a.standing, a.critical, a.resolved, scan);
}

int verdict_exit_code(const json& scan) {
  const auto& v = scan.contains("verdict") ? scan["verdict"] : json();
  const auto decision = v.is_object() ? v.value("decision", std::string()) : std::string();
  if (decision == "out_of_tolerance") return ctl_exit::out_of_tolerance;
  if (decision == "instrument_out_of_spec") return ctl_exit::instrument_out_of_spec;
  return ctl_exit::ok;
}

}  // namespace gonio::daemon::ctl
