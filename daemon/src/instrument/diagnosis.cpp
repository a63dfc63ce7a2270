// Diagnosis of a sustained divergence (see diagnosis.hpp).
#include "gonio/daemon/instrument/diagnosis.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "gonio/daemon/instrument/alerts.hpp"
#include "gonio/daemon/instrument/scan_twin.hpp"
#include "gonio/daemon/instrument/twin_service.hpp"
#include "gonio/daemon/store/store.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {

using nlohmann::json;

namespace {

// The points a refit uses: the whole scan up to this many (the newest), enough for any one
// parameter and few enough that the fit takes seconds.
constexpr std::size_t kMaxPoints = 400;

}  // namespace

std::optional<std::string> calibration_parameter(const std::string& p) {
  if (p == "incidence_arm_deg") return "incidence_offset_deg";
  if (p == "receive_arm_deg") return "receive_offset_deg";
  if (p == "gain") return "gain";
  if (p == "source_aperture_rel") return "source_aperture_scale";
  if (p == "receiver_aperture_rel") return "receiver_aperture_scale";
  return std::nullopt;
}

std::optional<std::string> fit_template(const std::string& spec, const std::string& name) {
  for (const auto& p : spec_parameters(spec, 64)) {
    if (p.name != name) continue;
    return spec.substr(0, p.offset) + '?' + spec.substr(p.offset);
  }
  return std::nullopt;
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
  const auto verdict = store_.latest_fit(job.scan_id, FitKind::verdict);
  if (!sample || !sample->spec.bsdf || !verdict) return;
  const auto& cause = verdict->result.contains("cause") ? verdict->result["cause"] : json(nullptr);
  if (!cause.is_object()) return;  // no cause named: nothing to refit
  const auto parameter = cause.value("parameter", "");
  const auto kind = cause.value("kind", "");

  const auto total = static_cast<std::size_t>(scan->points_done);
  const auto first = total > kMaxPoints ? total - kMaxPoints : 0;
  json records = json::array();
  for (const auto& p : store_.points(job.scan_id, first, kMaxPoints))
    if (p.predicted) records.push_back(p);
  if (records.empty()) return;
  auto data = twin::measured_from_json(records, fmt::format("scan {}", job.scan_id));
  data.validate();
  twin::FitOptions options;
  options.replicates = twin_.options().replicates;
  options.seed = twin_.options().seed;
  options.threads = twin_.threads();
  options.max_iterations = 30;
  options.naive = false;
  const auto profile = twin_.profile();

  twin::FitResult f;
  std::string model = *sample->spec.bsdf;
  if (kind == "sample") {
    const auto tmpl = fit_template(model, parameter);
    if (!tmpl) return;
    model = *tmpl;
    f = twin::fit_material(data, model, profile, options);
  } else {
    const auto name = calibration_parameter(parameter);
    if (!name) return;
    f = twin::calibrate(data, model, {*name}, profile, options);
  }
  if (f.parameters.size() != 1) return;
  const auto& p = f.parameters.front();
  const auto text = fmt::format(
      "diagnosis: the inverse twin refits {} to {:.5g} ± {:.2g} on {} points (χ²/dof {:.3g}{}{})",
      p.name, p.value, p.u, data.points.size(), f.chi2_per_dof, f.converged ? "" : ", not converged",
      p.at_bound ? ", on its bound" : "");
  json result{{"summary", text}, {"cause", cause}, {"fit", f.to_json()}};
  store_.insert_fit(job.scan_id, FitKind::diagnosis, model, result, "goniod");
  alerts_.annotate(job.alert_id, text);
}

}  // namespace gonio::daemon
