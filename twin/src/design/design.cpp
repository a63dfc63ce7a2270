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
