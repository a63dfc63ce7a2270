// The twin's per-point work for a scan (see scan_twin.hpp).
#include "gonio/daemon/instrument/scan_twin.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>

#include <fmt/format.h>

#include "gonio/daemon/instrument/catalogue.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {
namespace {

constexpr double kStep = 0.05;

bool parse_number(std::string_view s, double& v) {
  if (s.empty()) return false;
  const auto* end = s.data() + s.size();
  const auto r = std::from_chars(s.data(), end, v);
  return r.ec == std::errc() && r.ptr == end && std::isfinite(v);
}

double round_sig(double v, int digits) {
  if (v == 0 || !std::isfinite(v)) return v;
  const double scale = std::pow(10.0, digits - 1 - static_cast<int>(std::floor(std::log10(std::abs(v)))));
  return std::round(v * scale) / scale;
}

std::vector<double> rounded(const std::vector<double>& v) {
  std::vector<double> out;
  out.reserve(v.size());
  for (double x : v) out.push_back(round_sig(x, 4));
  return out;
}

}  // namespace

std::string SpecParameter::with(const std::string& spec, double v) const {
  std::string s = spec;
  s.replace(offset, length, fmt::format("{:.9g}", v));
  return s;
}

std::vector<SpecParameter> spec_parameters(const std::string& spec, std::size_t limit) {
  std::vector<SpecParameter> out;
  std::size_t pos = 0;
  while (pos <= spec.size() && out.size() < limit) {
    auto lobe_end = spec.find('+', pos);
    if (lobe_end == std::string::npos) lobe_end = spec.size();
    const auto colon = spec.find(':', pos);
    if (colon != std::string::npos && colon < lobe_end) {
      const std::string lobe = spec.substr(pos, colon - pos);
      std::string key;
      std::size_t item = colon + 1;
      while (item < lobe_end && out.size() < limit) {
        auto comma = spec.find(',', item);
        if (comma == std::string::npos || comma > lobe_end) comma = lobe_end;
        const std::string_view text(spec.data() + item, comma - item);
        std::size_t value_at = item;
        std::string_view value = text;
        if (const auto eq = text.find('='); eq != std::string_view::npos) {
          key = std::string(text.substr(0, eq));
          value = text.substr(eq + 1);
          value_at = item + eq + 1;
        }
        double v = 0, nm = 0;
        if (const auto c = value.find(':'); c != std::string_view::npos) {
          // a spectral node nm:value
          if (parse_number(value.substr(0, c), nm) && parse_number(value.substr(c + 1), v))
            out.push_back({fmt::format("{}.{}@{:g}", lobe, key, nm), v, value_at + c + 1, value.size() - c - 1});
        } else if (!key.empty() && parse_number(value, v)) {
          out.push_back({fmt::format("{}.{}", lobe, key), v, value_at, value.size()});
        }
        item = comma + 1;
      }
    }
    pos = lobe_end + 1;
  }
  return out;
}

ScanTwin::ScanTwin(std::shared_ptr<const twin::Twin> nominal, const std::string& spec,
                   const std::function<std::shared_ptr<const twin::Twin>(const std::string&)>& make,
                   CatalogueU catalogue_u)
    : nominal_(std::move(nominal)), budget_(*nominal_), catalogue_u_(std::move(catalogue_u)) {
  for (auto& p : spec_parameters(spec)) {
    const double h = p.value != 0 ? kStep * std::abs(p.value) : 0.01;
    for (double step : {h, -h}) {
      try {
        candidates_.push_back({p, step, make(p.with(spec, p.value + step))});
        break;
      } catch (const Error&) {
        // outside the model's range on this side: try the other
      }
    }
  }
}

ScanTwin::PointPrediction ScanTwin::predict(const Geometry& g, const twin::EstimatorOptions& options) const {
  PointPrediction out;
  out.prediction = nominal_->predict(g, options);
  out.budget = budget_.evaluate(out.prediction, options);
  if (catalogue_u_) add_catalogue_entry(out.budget, out.prediction.beta, catalogue_u_(g));
  const auto variant = twin::BudgetModel::variant_options(options, out.prediction.samples);
  const auto& base = out.budget.beta_base;
  for (const auto& c : candidates_) {
    const auto p = c.twin->predict(g, variant);
    SampleSensitivity s{c.parameter.name, c.parameter.value, {}};
    s.sensitivity.reserve(base.size());
    for (std::size_t k = 0; k < base.size(); ++k) s.sensitivity.push_back(round_sig((p.beta[k] - base[k]) / c.step, 6));
    out.sample.push_back(std::move(s));
  }
  return out;
}

std::vector<BudgetEntry> budget_entries(const twin::Budget& b) {
  std::vector<BudgetEntry> out;
  for (const auto& c : b.components) {
    const std::string dist(to_text(c.distribution));
    const bool curved = !c.random && std::any_of(c.curvature.begin(), c.curvature.end(), [](double v) { return v != 0; });
    out.push_back(BudgetEntry{c.name, dist, c.unit, c.random, rounded(c.u), rounded(c.sensitivity),
                              rounded(c.contribution), curved ? rounded(c.curvature) : std::vector<double>{},
                              c.cross.empty() ? std::string() : c.cross_with, rounded(c.cross)});
  }
  return out;
}

}  // namespace gonio::daemon
