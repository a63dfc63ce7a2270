#include "gonio/daemon/instrument/adaptive_loop.hpp"

#include <chrono>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/proto/error.hpp"

namespace gonio::daemon {

namespace {

twin::MeasuredPoint measured_of(const PointRecord& p) {
  twin::MeasuredPoint m;
  m.geometry = p.planned;
  m.beta = p.measured.values;
  m.u = p.measured.std_uncertainty;
  // A reading without an uncertainty cannot weigh a fit; the design needs u > 0.
  for (auto& u : m.u) u = std::max(u, 1e-9);
  return m;
}

std::unique_ptr<twin::Design> make_design(const ScanPlan& plan, const twin::InstrumentProfile& profile) {
  const auto& a = *plan.adaptive;
  if (a.mode == AdaptiveMode::curve) {
    twin::CurveDesignOptions o;
    o.tolerance = a.tolerance;
    return std::make_unique<twin::CurveDesign>(plan.geometries, o);
  }
  twin::ParameterDesignOptions o;
  o.target_rel_u = a.target_rel_u;
  // A refit per point: a smaller budget than an offline fit's, the global start only once.
  o.fit.samples = 1u << 12;
  o.fit.replicates = 8;
  o.fit.max_iterations = 30;
  try {
    return std::make_unique<twin::ParameterDesign>(a.model, plan.geometries, plan.wavelengths, profile, o);
  } catch (const Error& e) {
    throw Error(e.code(), fmt::format("adaptive.model: {}", e.what()), "adaptive.model");
  }
}

}  // namespace

void AdaptiveLoop::check(const ScanPlan& plan) {
  if (!plan.adaptive || plan.adaptive->mode != AdaptiveMode::parameters) return;
  try {
    (void)twin::ModelTemplate(plan.adaptive->model, plan.wavelengths);
  } catch (const Error& e) {
    throw Error(Errc::invalid_argument, fmt::format("adaptive.model: {}", e.what()), "adaptive.model");
  }
}

AdaptiveLoop::AdaptiveLoop(const ScanPlan& plan, const twin::InstrumentProfile& profile, Reachable reachable)
    : reachable_(std::move(reachable)) {
  if (!plan.adaptive) throw Error::invalid("adaptive", "the plan is not adaptive");
  design_ = make_design(plan, profile);
  design_->set_movable(reachable_);
  seeds_ = design_->seeds();
  counts_.assign(plan.geometries.size(), 0);
  status_ = design_->status();
}

AdaptiveLoop::~AdaptiveLoop() {
  if (job_.valid()) job_.wait();
}

void AdaptiveLoop::restore(const std::vector<PointRecord>& points) {
  std::lock_guard lock(mu_);
  for (const auto& p : points) {
    const auto c = static_cast<std::size_t>(p.geometry_index);
    if (c >= counts_.size())
      throw Error(Errc::invalid_state, fmt::format("stored point {} names geometry {}, not a candidate", p.index, c));
    queued_.emplace_back(c, measured_of(p));
    ++counts_[c];
    last_ = c;
  }
  taken_ = points.size();
  catch_up();
}

void AdaptiveLoop::catch_up() {
  if (queued_.empty()) return;
  for (auto& [c, m] : queued_) design_->add(c, m);
  queued_.clear();
  design_->set_timing(timing_.timing(prior_));
  design_->update();
  status_ = design_->status();
}

twin::DesignStatus AdaptiveLoop::timed(twin::DesignStatus s) const {
  twin::DesignStatus::Time t;
  t.timing = timing_.timing(prior_);
  t.moves_timed = timing_.moves();
  t.readings_timed = timing_.readings();
  t.seconds = timing_.seconds();
  t.waiting_seconds = waiting_s_;
  // From where this run's first point began, as the uniform scan would (its first point is
  // the first seed, the first candidate; after a restart, an estimate).
  const auto& cand = design_->candidates();
  t.uniform_seconds = first_move_s_ + t.timing.total_s(cand.front(), cand);
  s.time = t;
  return s;
}

std::optional<std::size_t> AdaptiveLoop::choose(const std::vector<std::size_t>& pending, const Geometry& arms) {
  // The seeds first (those still readable and reachable), then the design's choice —
  // none once the points in hand already reach the target.
  while (taken_ < seeds_.size()) {
    const auto c = seeds_[taken_];
    if (design_->available(c, pending) && reachable_(arms, design_->candidates()[c])) return c;
    ++taken_;
  }
  if (design_->target_reached()) return std::nullopt;
  return design_->next(pending, arms);
}

std::optional<std::size_t> AdaptiveLoop::first(const std::optional<Geometry>& arms) {
  std::lock_guard lock(mu_);
  const auto& cand = design_->candidates();
  if (taken_ >= seeds_.size() && design_->target_reached()) return std::nullopt;
  return choose({}, arms ? *arms : cand[last_.value_or(seeds_.empty() ? 0 : seeds_.front())]);
}

void AdaptiveLoop::measuring(std::size_t c) {
  if (job_.valid()) job_.wait();
  ++taken_;
  ++counts_.at(c);
  last_ = c;
  job_ = std::async(std::launch::async, [this, c]() -> std::optional<std::size_t> {
    std::lock_guard lock(mu_);
    catch_up();
    return choose({c}, design_->candidates()[c]);
  });
}

void AdaptiveLoop::committed(std::size_t c, const PointRecord& p, const PointTiming& t) {
  std::lock_guard lock(mu_);
  queued_.emplace_back(c, measured_of(p));
  if (timing_.readings() == 0) first_move_s_ = t.move_s;
  timing_.move(t.travel_deg, t.move_s);
  timing_.reading(t.reading_s);
}

std::optional<std::size_t> AdaptiveLoop::next_after(std::size_t c) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto waited = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  std::optional<std::size_t> next;
  if (job_.valid()) next = job_.get();
  if (next) {
    std::lock_guard lock(mu_);
    waiting_s_ += waited();
    return next;
  }
  // The design expects the target with the points in hand: this point's reading decides.
  std::lock_guard lock(mu_);
  catch_up();
  if (!design_->target_reached()) next = choose({}, design_->candidates()[c]);
  waiting_s_ += waited();
  return next;
}

twin::DesignStatus AdaptiveLoop::status() const {
  std::lock_guard lock(mu_);
  return timed(status_);
}

twin::DesignStatus AdaptiveLoop::finish(bool at_max_points) {
  if (job_.valid()) job_.wait();
  std::lock_guard lock(mu_);
  catch_up();
  status_ = design_->status();
  if (status_.state != twin::DesignState::target_reached && at_max_points)
    status_.state = twin::DesignState::max_points;
  return timed(status_);
}

}  // namespace gonio::daemon
