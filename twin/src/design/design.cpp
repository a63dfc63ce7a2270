// The parts every design shares: the timing model, the status, the record of what is measured.
#include "gonio/twin/design.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"

namespace gonio::twin {

void ScanTiming::validate() const {
  if (!(speed_deg_s >= 0.1 && speed_deg_s <= 1000))
    throw Error::out_of_range("timing.speed_deg_s", speed_deg_s, 0.1, 1000, "°/s");
  if (!(settle_s >= 0 && settle_s <= 60)) throw Error::out_of_range("timing.settle_s", settle_s, 0, 60, "s");
  if (!(reading_s >= 0 && reading_s <= 3600))
    throw Error::out_of_range("timing.reading_s", reading_s, 0, 3600, "s");
}

double ScanTiming::move_s(const Geometry& from, const Geometry& to) const {
  // goniod moves the arms one after the other (docs/architecture.md §6 step 3), and the
  // sample's rotation after them.
  const double travel = std::abs(to.theta_i - from.theta_i) + std::abs(to.theta_r - from.theta_r) +
                        std::abs(to.phi_i - from.phi_i);
  if (travel < 1e-9) return 0;
  return travel / speed_deg_s + settle_s;
}

double ScanTiming::total_s(const Geometry& start, const std::vector<Geometry>& sequence) const {
  double t = 0;
  const Geometry* at = &start;
  for (const auto& g : sequence) {
    t += point_s(*at, g);
    at = &g;
  }
  return t;
}

void TimingRecord::move(double travel_deg, double seconds) {
  total_s_ += seconds;
  if (travel_deg <= 1e-9) return;  // the arms stayed: nothing to learn about a move
  travel_.push_back(travel_deg);
  move_s_.push_back(seconds);
}

void TimingRecord::reading(double seconds) {
  total_s_ += seconds;
  reading_s_.push_back(seconds);
}

ScanTiming TimingRecord::timing(const ScanTiming& prior) const {
  ScanTiming t = prior;
  if (!reading_s_.empty()) {
    auto r = reading_s_;
    std::nth_element(r.begin(), r.begin() + static_cast<long>(r.size() / 2), r.end());
    t.reading_s = std::clamp(r[r.size() / 2], 0.0, 3600.0);
  }
  // seconds = settle + travel/speed, by least squares over the moves.
  const auto n = static_cast<double>(travel_.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t k = 0; k < travel_.size(); ++k) {
    sx += travel_[k];
    sy += move_s_[k];
    sxx += travel_[k] * travel_[k];
    sxy += travel_[k] * move_s_[k];
  }
  const double var = n * sxx - sx * sx;
  if (travel_.size() >= 2 && var > 1e-9 * n * sxx) {
    const double per_deg = (n * sxy - sx * sy) / var;
    t.settle_s = std::clamp((sy - per_deg * sx) / n, 0.0, 60.0);
    t.speed_deg_s = per_deg > 1e-3 ? std::clamp(1 / per_deg, 0.1, 1000.0) : 1000.0;
  }
  return t;
}

nlohmann::json DesignStatus::to_json() const {
  nlohmann::json j{{"mode", to_text(mode)}, {"state", to_text(state)}, {"points_used", points_used}};
  if (mode == AdaptiveMode::parameters) {
    auto ps = nlohmann::json::array();
    for (const auto& p : parameters) ps.push_back({{"name", p.name}, {"value", p.value}, {"u", p.u}});
    j["parameters"] = std::move(ps);
    j["chi2_per_dof"] = chi2_per_dof ? nlohmann::json(*chi2_per_dof) : nlohmann::json(nullptr);
    j["misfit"] = misfit;
  } else {
    j["estimated_error"] = estimated_error ? nlohmann::json(*estimated_error) : nlohmann::json(nullptr);
  }
  j["warnings"] = warnings;
  if (time)
    j["time"] = {{"speed_deg_s", time->timing.speed_deg_s},
                 {"settle_s", time->timing.settle_s},
                 {"reading_s", time->timing.reading_s},
                 {"moves_timed", time->moves_timed},
                 {"readings_timed", time->readings_timed},
                 {"seconds", time->seconds},
                 {"waiting_seconds", time->waiting_seconds},
                 {"uniform_seconds", time->uniform_seconds},
                 {"saved_seconds", time->uniform_seconds - time->seconds}};
  return j;
}

ArmReach::ArmReach(const InstrumentProfile& profile)
    : clearance(profile.arms.min_separation_deg, "profile.arms.min_separation_deg"),
      calibration(profile.calibration.geometry),
      side(clearance.side(calibration)) {}

bool ArmReach::reaches(const Geometry& g) const {
  return clearance.clear(g) && (!side || clearance.side(g) == side);
}

std::string ArmReach::why_not(const Geometry& g) const {
  if (auto why = clearance.why_not_clear(g); !why.empty()) return why;
  if (side && clearance.side(g) != side)
    return fmt::format("on the other side of the collision zone from the arms, which work on the "
                       "side of {} (the calibration geometry): the arms cannot pass through each "
                       "other (minimum separation {:g}°)",
                       calibration.to_string(), clearance.min_separation_deg());
  return {};
}

void ArmReach::check(const std::vector<Geometry>& candidates, std::string_view field) const {
  ArmReach reach = *this;
  if (!reach.side && !candidates.empty()) reach.side = clearance.side(candidates.front());
  for (std::size_t k = 0; k < candidates.size(); ++k)
    if (const auto why = reach.why_not(candidates[k]); !why.empty()) {
      const auto f = fmt::format("{}[{}]", field, k);
      throw Error(Errc::plan_rejected, fmt::format("{} ({}): {}", f, candidates[k].to_string(), why), f);
    }
}

Design::Design(std::vector<Geometry> candidates, int max_readings)
    : candidates_(std::move(candidates)), max_readings_(max_readings) {
  if (candidates_.empty()) throw Error::invalid("geometries", "an adaptive scan needs candidate geometries");
  if (max_readings < 1 || max_readings > 100) throw Error::out_of_range("max_readings", max_readings, 1, 100);
  readings_.assign(candidates_.size(), 0);
}

int Design::readings(std::size_t c) const { return c < readings_.size() ? readings_[c] : 0; }

bool Design::available(std::size_t c, const std::vector<std::size_t>& pending) const {
  return readings(c) + static_cast<int>(std::count(pending.begin(), pending.end(), c)) < max_readings_;
}

void Design::mark(std::size_t c) {
  if (c >= candidates_.size())
    throw Error::out_of_range("candidate", static_cast<double>(c), 0, static_cast<double>(candidates_.size() - 1));
  if (readings_[c] >= max_readings_)
    throw Error(Errc::invalid_state, fmt::format("candidate {} ({}) has been read {} times already, the most allowed",
                                                 c, candidates_[c].to_string(), readings_[c]));
  ++readings_[c];
  measured_.push_back(c);
}

}  // namespace gonio::twin
