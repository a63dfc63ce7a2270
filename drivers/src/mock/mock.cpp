// The mock instrument (mock.hpp): a virtual lab shared by a MotionController and a
// Photometer. Readings come from the twin at the geometry where the arms stand; noise,
// lamp drift and faults are drawn from one seeded generator on a virtual clock, so a run
// is the same for the same seed and the same sequence of calls.
#include "gonio/sim/mock/mock.hpp"

#include <atomic>
#include <cmath>
#include <condition_variable>
#include <map>
#include <mutex>
#include <random>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"
#include "gonio/twin/twin.hpp"

namespace gonio::drivers::mock {

struct Faults {
  int disconnect_at_point = 0, timeout_at_point = 0, garbage_at_point = 0, saturate_at_point = 0;
  int dark_reference_at_point = 0;  // the reference white reads nothing (a shutter stuck closed)
  int stall_at_move = 0;
  milliseconds timeout_wait{200};
  milliseconds reconnect_after{0};  // how long the photometer stays unplugged
};

struct LabConfig {
  twin::InstrumentProfile profile;
  nlohmann::json sample = "lambert:albedo=0.5";
  WavelengthGrid grid = WavelengthGrid::visible();
  double lamp_drift_per_s = 0;
  double beta_gain = 1;  // hidden: the sample's β is reported this many times too large
  double gain = 400, dark = 2, read_noise = 3, full_scale = 1e6, integration_ms = 100;
  double speed_deg_s = 20, time_scale = 0;
  // Each move lands within ±this of its target, uniformly (seeded): where the light goes,
  // not what the encoder reports (the arm is read back at its target, as an open-loop
  // stepper would be).
  double position_repeatability_deg = 0;
  std::uint64_t seed = 1;
  twin::EstimatorOptions estimator;
  Faults faults;
};

namespace {

int fault_index(json_util::ObjectReader& r, const char* key) {
  return r.optional_in<int>(key, 0, 0, 1000000);
}

LabConfig read_config(const nlohmann::json& j) {
  LabConfig c;
  json_util::ObjectReader r(j, "mock");
  c.profile = twin::InstrumentProfile::load(r.optional<std::string>("profile", "gcms4"));
  if (const auto* s = r.raw("sample"); s != nullptr) c.sample = *s;
  if (r.has("wavelengths"))
    c.grid = WavelengthGrid::parse(r.required<std::string>("wavelengths"), r.path("wavelengths"));
  if (const auto* a = r.raw("arm_offsets_deg"); a != nullptr) {
    json_util::ObjectReader ar(*a, r.path("arm_offsets_deg"));
    c.profile.arms.incidence_offset_deg = ar.optional_in<double>("incidence", 0, -10, 10);
    c.profile.arms.receive_offset_deg = ar.optional_in<double>("receive", 0, -10, 10);
    ar.finish();
  }
  c.lamp_drift_per_s = r.optional_in<double>("lamp_drift_per_s", 0, -0.1, 0.1);
  c.beta_gain = r.optional_in<double>("gain", 1, 0.1, 10);
  c.gain = r.optional_in<double>("gain_counts_per_ms", c.gain, 0, 1e9);
  c.dark = r.optional_in<double>("dark_counts_per_ms", c.dark, 0, 1e9);
  c.read_noise = r.optional_in<double>("read_noise_counts", c.read_noise, 0, 1e9);
  c.full_scale = r.optional_in<double>("full_scale_counts", c.full_scale, 1, 1e15);
  c.integration_ms = r.optional_in<double>("integration_ms", c.integration_ms, 0.01, 60000);
  c.speed_deg_s = r.optional_in<double>("speed_deg_s", c.speed_deg_s, 0.01, 1000);
  c.position_repeatability_deg =
      r.optional_in<double>("position_repeatability_deg", c.position_repeatability_deg, 0, 5, "°");
  c.time_scale = r.optional_in<double>("time_scale", c.time_scale, 0, 10);
  c.seed = r.optional<std::uint64_t>("seed", c.seed);
  c.estimator.rel_se = 1e-2;
  c.estimator.max_samples = 1u << 16;
  c.estimator.replicates = 8;
  if (const auto* e = r.raw("estimator"); e != nullptr) {
    json_util::ObjectReader er(*e, r.path("estimator"));
    c.estimator.rel_se = er.optional_in<double>("rel_se", c.estimator.rel_se, 1e-6, 1);
    c.estimator.max_samples = er.optional<std::uint64_t>("max_samples", c.estimator.max_samples);
    c.estimator.replicates = er.optional<int>("replicates", c.estimator.replicates);
    er.finish();
  }
  c.estimator.seed = c.seed;
  c.estimator.validate();
  if (const auto* f = r.raw("faults"); f != nullptr) {
    json_util::ObjectReader fr(*f, r.path("faults"));
    c.faults.disconnect_at_point = fault_index(fr, "disconnect_at_point");
    c.faults.timeout_at_point = fault_index(fr, "timeout_at_point");
    c.faults.garbage_at_point = fault_index(fr, "garbage_at_point");
    c.faults.saturate_at_point = fault_index(fr, "saturate_at_point");
    c.faults.dark_reference_at_point = fault_index(fr, "dark_reference_at_point");
    c.faults.stall_at_move = fault_index(fr, "stall_at_move");
    c.faults.timeout_wait = milliseconds(static_cast<long long>(fr.optional_in<double>("timeout_wait_ms", 200, 0, 600000)));
    c.faults.reconnect_after = milliseconds(static_cast<long long>(fr.optional_in<double>("reconnect_after_ms", 0, 0, 86400000)));
    fr.finish();
  }
  r.finish();
  c.profile.validate();
  return c;
}

std::size_t axis_index(Axis a) { return static_cast<std::size_t>(a); }

}  // namespace

devsim::BetaSource twin_beta_source(std::shared_ptr<const twin::Twin> tw,
                                    const twin::EstimatorOptions& options) {
  struct Cache {
    std::mutex mu;
    std::map<std::array<double, 4>, std::vector<double>> beta;
  };
  auto cache = std::make_shared<Cache>();
  return [tw, options, cache](const Geometry& g) {
    const std::array<double, 4> key{g.theta_i, g.phi_i, g.theta_r, g.phi_r};
    {
      std::lock_guard lock(cache->mu);
      if (const auto it = cache->beta.find(key); it != cache->beta.end()) return it->second;
    }
    auto beta = tw->predict(g, options).beta;
    std::lock_guard lock(cache->mu);
    if (cache->beta.size() > 4096) cache->beta.clear();
    cache->beta.emplace(key, beta);
    return beta;
  };
}

class Lab {
 public:
  explicit Lab(LabConfig c)
      : cfg_(std::move(c)), rng_(cfg_.seed) {
    auto bsdf = twin::make_bsdf(cfg_.sample, cfg_.grid);
    twin_ = std::make_shared<twin::Twin>(cfg_.profile, std::move(bsdf), cfg_.grid);
    beta_ = twin_beta_source(twin_, cfg_.estimator);
    pos_ = {0, 45, 0, 0};  // arms apart at rest
    integration_ms_ = cfg_.integration_ms;
  }

  const LabConfig& config() const { return cfg_; }

  // The photometer's link: a handle opened at `epoch` works while the link is up and has
  // not been lost since (a replug gives a new device node; the old handle stays dead).
  void check_link(std::uint64_t epoch) const {
    std::lock_guard lock(mu_);
    check_link_locked(epoch);
  }

  // A new photometer handle, as the driver would open after a replug: refused while the
  // photometer is still unplugged (reconnect_after_ms after the loss).
  std::uint64_t connect_photometer() {
    std::lock_guard lock(mu_);
    if (disconnected_) {
      const auto back = lost_at_ + cfg_.faults.reconnect_after;
      if (Clock::now() < back)
        throw Error(Errc::disconnected,
                    fmt::format("mock photometer: still unplugged (back {} ms after the loss)",
                                cfg_.faults.reconnect_after.count()));
      disconnected_ = false;
      spdlog::info("mock photometer: plugged in again");
    }
    return epoch_;
  }

  // ---- motion ----
  void move(Axis a, double target, milliseconds timeout) {
    std::unique_lock lock(mu_);
    stop_ = false;
    const double from = pos_[axis_index(a)];
    ++moves_;
    const bool stall = cfg_.faults.stall_at_move == moves_;
    const double dest = stall ? from + 0.5 * (target - from) : target;
    const double seconds = std::fabs(dest - from) / cfg_.speed_deg_s;
    if (cfg_.time_scale > 0) {
      const auto real = std::chrono::duration<double>(seconds * cfg_.time_scale);
      if (real > timeout) {
        lock.unlock();
        sleep_interruptible(timeout);
        throw Error(Errc::timeout, fmt::format("mock {}: move to {:g}° did not finish in {} ms",
                                               to_text(a), target, timeout.count()));
      }
      lock.unlock();
      sleep_interruptible(std::chrono::duration_cast<milliseconds>(real));
      lock.lock();
      if (stop_) throw Error(Errc::invalid_state, fmt::format("mock {}: move stopped", to_text(a)));
    }
    clock_s_ += seconds;
    pos_[axis_index(a)] = dest;
    if (cfg_.position_repeatability_deg > 0) {
      std::uniform_real_distribution<double> land(-cfg_.position_repeatability_deg,
                                                  cfg_.position_repeatability_deg);
      landed_[axis_index(a)] = land(motion_rng_);
    }
    if (stall) {
      alarm_[axis_index(a)] = 0x10;
      throw Error(Errc::device_alarm,
                  fmt::format("mock {}: alarm 0x10 (excessive position deviation): stalled at {:g}° "
                              "on the way to {:g}°", to_text(a), dest, target));
    }
  }

  double position(Axis a) {
    std::lock_guard lock(mu_);
    return pos_[axis_index(a)];
  }

  AxisStatus status(Axis a) {
    std::lock_guard lock(mu_);
    AxisStatus s;
    s.alarm_code = alarm_[axis_index(a)];
    s.alarm = s.alarm_code != 0;
    s.ready = !s.alarm;
    s.in_position = !s.alarm;
    s.position_deg = s.command_deg = pos_[axis_index(a)];
    s.home_end = homed_[axis_index(a)];
    return s;
  }

  void home(Axis a, milliseconds timeout) {
    move(a, 0, timeout);
    std::lock_guard lock(mu_);
    homed_[axis_index(a)] = true;
  }

  void reset_alarm(Axis a) {
    std::lock_guard lock(mu_);
    alarm_[axis_index(a)] = 0;
  }

  void stop() {
    stop_ = true;
    cv_.notify_all();
  }

  // ---- photometer ----
  Reading measure(Channel ch, milliseconds timeout, std::uint64_t epoch) {
    std::unique_lock lock(mu_);
    check_link_locked(epoch);
    int point = 0;
    if (ch == Channel::sample) point = ++points_;
    const auto& f = cfg_.faults;
    if (point != 0 && point == f.disconnect_at_point) {  // unplugged: this handle dies
      disconnected_ = true;
      ++epoch_;
      lost_at_ = Clock::now();
      check_link_locked(epoch);
    }
    if (point != 0 && point == f.timeout_at_point) {
      lock.unlock();
      sleep_interruptible(std::min(timeout, f.timeout_wait));
      throw Error(Errc::timeout, fmt::format("mock photometer: no reply to reading {} (scripted fault)", point));
    }
    if (point != 0 && point == f.garbage_at_point)
      throw Error(Errc::protocol_error,
                  fmt::format("mock photometer: reading {} is garbage (scripted fault)", point));
    const double t = integration_ms_;
    clock_s_ += t / 1000;
    const double lamp = 1 + cfg_.lamp_drift_per_s * clock_s_;
    std::vector<double> beta(cfg_.grid.size(), 0.0);
    if (ch == Channel::sample) {
      lock.unlock();  // the twin may take a while; the lab stays usable (stop())
      beta = beta_(geometry());
      lock.lock();
      for (auto& b : beta) b *= cfg_.beta_gain;
    } else if (ch == Channel::reference) {
      beta.assign(cfg_.grid.size(), 1.0);
    }
    Reading r;
    r.channel = ch;
    r.unit = "counts";
    r.integration_ms = t;
    std::vector<double> val(beta.size()), unc(beta.size());
    std::normal_distribution<double> gauss(0, 1);
    for (std::size_t i = 0; i < beta.size(); ++i) {
      const double mean = cfg_.dark * t + cfg_.gain * t * lamp * std::max(0.0, beta[i]);
      const double sd = std::sqrt(mean + cfg_.read_noise * cfg_.read_noise);
      double v = mean + sd * gauss(rng_);
      if (v >= cfg_.full_scale) {
        v = cfg_.full_scale;
        r.saturated = true;
      }
      val[i] = std::max(0.0, v);
      unc[i] = sd;
    }
    if (point != 0 && point == f.saturate_at_point) {
      r.saturated = true;
      val.assign(val.size(), cfg_.full_scale);
    }
    // The reference read for the next sample reading.
    if (ch == Channel::reference && points_ + 1 == f.dark_reference_at_point) val.assign(val.size(), 0.0);
    r.spectrum = Spectrum(cfg_.grid, std::move(val), std::move(unc));
    return r;
  }

  double integration_ms(std::uint64_t epoch) {
    std::lock_guard lock(mu_);
    check_link_locked(epoch);
    return integration_ms_;
  }
  void set_integration_ms(double ms, std::uint64_t epoch) {
    std::lock_guard lock(mu_);
    check_link_locked(epoch);
    if (!(ms >= 0.01 && ms <= 60000)) throw Error::out_of_range("integration_ms", ms, 0.01, 60000, " ms");
    integration_ms_ = ms;
  }

  // The nominal geometry where the arms stand, and where the last moves landed (the twin
  // adds the arm offsets itself).
  Geometry geometry() {
    std::lock_guard lock(mu_);
    double ti = pos_[axis_index(Axis::incidence)] + landed_[axis_index(Axis::incidence)];
    double tr = pos_[axis_index(Axis::receive)] + landed_[axis_index(Axis::receive)];
    if (ti < 0) {  // mirror image: same configuration for the plane of measurement
      ti = -ti;
      tr = -tr;
    }
    ti = std::min(ti, Geometry::kMaxIncidence);
    const double phi = -pos_[axis_index(Axis::rotation)];
    Geometry g{ti, phi, tr, phi};
    g.phi_i = std::remainder(g.phi_i, 360.0);
    g.phi_r = g.phi_i;
    return g;
  }

  std::shared_ptr<const twin::Twin> twin() const { return twin_; }
  int points() const {
    std::lock_guard lock(mu_);
    return points_;
  }

 private:
  using Clock = std::chrono::steady_clock;

  void check_link_locked(std::uint64_t epoch) const {
    if (disconnected_ || epoch != epoch_)
      throw Error(Errc::disconnected, "mock photometer: link lost (scripted fault: unplugged)");
  }

  void sleep_interruptible(milliseconds d) {
    std::unique_lock lock(sleep_mu_);
    cv_.wait_for(lock, d, [&] { return stop_.load(); });
  }

  LabConfig cfg_;
  std::shared_ptr<twin::Twin> twin_;
  devsim::BetaSource beta_;
  mutable std::mutex mu_;
  std::mutex sleep_mu_;
  std::condition_variable cv_;
  std::atomic<bool> stop_{false};
  std::mt19937_64 rng_;
  std::mt19937_64 motion_rng_{cfg_.seed ^ 0x9e3779b97f4a7c15ull};  // apart from the noise's
  std::array<double, 4> pos_{};
  std::array<double, 4> landed_{};  // where the last move of each axis landed, off its target
  std::array<std::uint32_t, 4> alarm_{};
  std::array<bool, 4> homed_{};
  double clock_s_ = 0;
  double integration_ms_ = 100;
  int moves_ = 0, points_ = 0;
  bool disconnected_ = false;
  std::uint64_t epoch_ = 0;  // photometer link generation: + 1 at every loss
  Clock::time_point lost_at_{};
};

namespace {

class MockMotion final : public MotionController {
 public:
  explicit MockMotion(std::shared_ptr<Lab> lab) : lab_(std::move(lab)) {}
  MotionCapabilities capabilities() const override { return {}; }
  std::vector<Axis> axes() const override { return {kAllAxes.begin(), kAllAxes.end()}; }
  void move(Axis a, double target, milliseconds timeout) override { lab_->move(a, target, timeout); }
  double position(Axis a, milliseconds) override { return lab_->position(a); }
  AxisStatus status(Axis a, milliseconds) override { return lab_->status(a); }
  void home(Axis a, milliseconds timeout) override { lab_->home(a, timeout); }
  std::optional<double> home_position(Axis) const override { return 0.0; }  // Lab::home
  void reset_alarm(Axis a, milliseconds) override { lab_->reset_alarm(a); }
  void stop(milliseconds) override { lab_->stop(); }

 private:
  std::shared_ptr<Lab> lab_;
};

class MockPhotometer final : public Photometer {
 public:
  explicit MockPhotometer(std::shared_ptr<Lab> lab)
      : lab_(std::move(lab)), epoch_(lab_->connect_photometer()) {}
  PhotometerCapabilities capabilities() const override { return {true, true, true, true}; }
  Identity identify(milliseconds) override {
    lab_->check_link(epoch_);
    return {"GONIO", "MOCK", fmt::format("seed-{}", lab_->config().seed), "1.0"};
  }
  WavelengthGrid wavelengths(milliseconds) override {
    lab_->check_link(epoch_);
    return lab_->config().grid;
  }
  double integration_ms(milliseconds) override { return lab_->integration_ms(epoch_); }
  void set_integration_ms(double ms, milliseconds) override { lab_->set_integration_ms(ms, epoch_); }
  Reading measure(Channel ch, milliseconds timeout, SaturationPolicy policy) override {
    auto r = lab_->measure(ch, timeout, epoch_);
    check_saturation(r, policy);
    return r;
  }
  void cancel() noexcept override { lab_->stop(); }

 private:
  std::shared_ptr<Lab> lab_;
  std::uint64_t epoch_;
};

}  // namespace

MockInstrument make_mock(const nlohmann::json& config) {
  auto lab = std::make_shared<Lab>(read_config(config));
  return {std::make_unique<MockMotion>(lab), std::make_unique<MockPhotometer>(lab), lab};
}

std::unique_ptr<MotionController> connect_motion(const std::shared_ptr<Lab>& lab) {
  return std::make_unique<MockMotion>(lab);
}

std::unique_ptr<Photometer> connect_photometer(const std::shared_ptr<Lab>& lab) {
  return std::make_unique<MockPhotometer>(lab);
}

std::unique_ptr<MotionController> make_mock_motion(const nlohmann::json& config) {
  return std::move(make_mock(config).motion);
}

std::unique_ptr<Photometer> make_mock_photometer(const nlohmann::json& config) {
  return std::move(make_mock(config).photometer);
}

double default_min_separation(const nlohmann::json& config) {
  return read_config(config).profile.arms.min_separation_deg;
}

}  // namespace gonio::drivers::mock
