// Diagnosis of a sustained divergence (see diagnosis.hpp).
#include "gonio/daemon/diagnosis.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "gonio/daemon/alerts.hpp"
#include "gonio/daemon/store.hpp"
#include "gonio/daemon/twin_service.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {

using nlohmann::json;

namespace {

// The most recent points a diagnosis fits: enough to pin an offset or a gain, few enough
// that the three fits take seconds.
constexpr std::size_t kMaxPoints = 200;

// A one-parameter fit has no flat direction to detect: a parameter the points do not
// constrain shows as an uncertainty wider than the range it may take.
bool determined(const twin::FittedParameter& p) { return std::isfinite(p.u) && p.u < p.hi - p.lo; }

bool usable(const twin::FitResult& f) {
  if (!f.converged || f.parameters.size() != 1 || !f.degenerate.empty()) return false;
  const auto& p = f.parameters.front();
  return !p.at_bound && p.identifiable && determined(p) && std::isfinite(p.value) &&
         std::isfinite(f.chi2_per_dof);
}

// A converged fit that ended on its bound: the divergence may be larger than the range the
// diagnosis fits (a gain of 2 for a sample twice as bright as its reference).
bool on_bound(const twin::FitResult& f) {
  return f.converged && f.parameters.size() == 1 && f.parameters.front().at_bound &&
         std::isfinite(f.chi2_per_dof);
}

// What a diagnosis parameter is, in the alert's words.
const char* subject(const std::string& name) {
  if (name == "gain") return "a reference-white gain";
  return name == "incidence_offset_deg" ? "an incidence-arm offset" : "a receive-arm offset";
}

// "a receive-arm offset of −0.212 ± 0.020°"
std::string describe(const twin::FitResult& f) {
  const auto& p = f.parameters.front();
  if (p.name == "gain") return fmt::format("{} of {:.4f} ± {:.4f}", subject(p.name), p.value, p.u);
  return fmt::format("{} of {:+.3f} ± {:.3f}°", subject(p.name), p.value, p.u);
}

}  // namespace

const std::vector<std::string>& diagnosis_parameters() {
  static const std::vector<std::string> names{"receive_offset_deg", "incidence_offset_deg", "gain"};
  return names;
}

std::optional<double> chi2_per_dof(const std::vector<PointRecord>& points) {
  double chi2 = 0;
  std::size_t n = 0;
  for (const auto& p : points) {
    if (!p.predicted) continue;
    const auto& m = p.measured;
    const auto& q = *p.predicted;
    for (std::size_t k = 0; k < m.size() && k < q.size(); ++k) {
      const double u = m.std_uncertainty.size() > k ? m.std_uncertainty[k] : 0;
      const double s = q.std_uncertainty.size() > k ? q.std_uncertainty[k] : 0;
      const double var = u * u + s * s;
      if (!(var > 0)) continue;
      const double d = m.values[k] - q.values[k];
      chi2 += d * d / var;
      ++n;
    }
  }
  if (n == 0) return std::nullopt;
  return chi2 / static_cast<double>(n);
}

Verdict explain(double before, const std::vector<twin::FitResult>& candidates) {
  Verdict v;
  std::optional<std::size_t> bound;  // the best fit that ended on its bound
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const auto c = candidates[i].chi2_per_dof;
    if (on_bound(candidates[i]) && (!bound || c < candidates[*bound].chi2_per_dof)) bound = i;
    if (!usable(candidates[i])) continue;
    if (!v.best || c < candidates[*v.best].chi2_per_dof) v.best = i;
  }
  // Said when a fit on its bound does better than any usable one: the likeliest cause lies
  // beyond the range fitted, which the technician should know rather than a poorer answer.
  std::string beyond;
  if (bound && (!v.best || candidates[*bound].chi2_per_dof < candidates[*v.best].chi2_per_dof)) {
    const auto& p = candidates[*bound].parameters.front();
    beyond = fmt::format("; {} at the end of its range ({:g}) fits best (χ²/dof {:.3g} → {:.3g}): "
                         "the difference may lie beyond what the diagnosis fits",
                         subject(p.name), p.value, before, candidates[*bound].chi2_per_dof);
  }
  if (!v.best) {
    v.text = "diagnosis: no arm offset or gain could be fitted to the scan's points" + beyond +
             "; the sample may differ from its reference BSDF";
    return v;
  }
  const auto& best = candidates[*v.best];
  v.explained = best.chi2_per_dof <= kExplainedChi2 && best.chi2_per_dof <= 0.25 * before;
  if (!v.explained) {
    if (!beyond.empty())
      v.text = "diagnosis: no single arm offset or gain within the fitted ranges explains it" + beyond +
               "; the sample may differ from its reference BSDF";
    else
      v.text = fmt::format("diagnosis: no single arm offset or gain explains it (best: {}, χ²/dof "
                           "{:.3g} → {:.3g}); the sample may differ from its reference BSDF",
                           describe(best), before, best.chi2_per_dof);
    return v;
  }
  // Others as good (within 50 % of the best χ²/dof and explaining too): the data cannot tell
  // them apart, so the alert names them all rather than pick one by noise.
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    if (i == *v.best || !usable(candidates[i])) continue;
    const double c = candidates[i].chi2_per_dof;
    if (c <= kExplainedChi2 && c <= 0.25 * before && c <= 1.5 * best.chi2_per_dof) v.alike.push_back(i);
  }
  v.text = fmt::format("diagnosis: consistent with {} (χ²/dof {:.3g} → {:.3g})", describe(best),
                       before, best.chi2_per_dof);
  for (auto i : v.alike)
    v.text += fmt::format("; equally with {} (χ²/dof {:.3g})", describe(candidates[i]),
                          candidates[i].chi2_per_dof);
  return v;
}

Diagnoser::Diagnoser(Store& store, TwinService& twin, AlertService& alerts)
    : store_(store), twin_(twin), alerts_(alerts), thread_([this] { work(); }) {}

Diagnoser::~Diagnoser() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
    queue_.clear();
  }
  cv_.notify_all();
  thread_.join();
}

void Diagnoser::request(std::int64_t scan_id, std::int64_t alert_id) {
  {
    std::lock_guard lock(mu_);
    if (stopping_) return;
    if (std::any_of(queue_.begin(), queue_.end(), [&](const Job& j) { return j.scan_id == scan_id; }))
      return;
    queue_.push_back(Job{scan_id, alert_id});
  }
  cv_.notify_all();
}

void Diagnoser::work() {
  for (;;) {
    Job job;
    {
      std::unique_lock lock(mu_);
      cv_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      job = queue_.front();
      queue_.pop_front();
    }
    try {
      diagnose(job);
    } catch (const std::exception& e) {
      // A diagnosis is advice: its failure is logged and never touches the scan.
      spdlog::warn("scan {}: no diagnosis of the divergence: {}", job.scan_id, e.what());
    }
  }
}

void Diagnoser::diagnose(const Job& job) {
  const auto scan = store_.scan(job.scan_id);
  if (!scan) return;
  const auto sample = store_.sample(scan->plan.sample_id);
  if (!sample || !sample->spec.bsdf) return;
  const auto total = static_cast<std::size_t>(scan->points_done);
  const auto first = total > kMaxPoints ? total - kMaxPoints : 0;
  const auto points = store_.points(job.scan_id, first, kMaxPoints);
  const auto before = chi2_per_dof(points);
  if (!before) return;

  json records = json::array();
  for (const auto& p : points) records.push_back(p);
  auto data = twin::measured_from_json(records, fmt::format("scan {}", job.scan_id));
  data.validate();
  twin::FitOptions options;
  options.replicates = twin_.options().replicates;
  options.seed = twin_.options().seed;
  options.threads = twin_.threads();
  options.max_iterations = 30;
  options.naive = false;
  const auto profile = twin_.profile();

  std::vector<twin::FitResult> candidates;
  json tried = json::array();
  for (const auto& name : diagnosis_parameters()) {
    twin::FitResult f;
    try {
      f = twin::calibrate(data, *sample->spec.bsdf, {name}, profile, options);
    } catch (const Error& e) {
      f.kind = "calibrate";
      f.status = e.what();
    }
    tried.push_back(f.to_json());
    candidates.push_back(std::move(f));
  }
  const auto verdict = explain(*before, candidates);
  json result{{"summary", verdict.text},
              {"explained", verdict.explained},
              {"chi2_per_dof_before", *before},
              {"points", points.size()},
              {"candidates", std::move(tried)}};
  store_.insert_fit(job.scan_id, "diagnosis", *sample->spec.bsdf, result, "goniod");
  alerts_.annotate(job.alert_id, verdict.text);
}

}  // namespace gonio::daemon
