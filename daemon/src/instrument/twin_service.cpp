// The twin's worker pool and look-ahead prediction batches (see twin_service.hpp).
#include "gonio/daemon/instrument/twin_service.hpp"

#include <atomic>
#include <future>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"
#include "gonio/twin/bsdf.hpp"

#include "gonio/proto/version.hpp"

namespace gonio::daemon {

namespace {

std::string make_version(const twin::EstimatorOptions& o, const std::string& profile,
                         std::int64_t profile_version) {
  return fmt::format("gonio-twin {} rqmc rel_se={} R={} seed={} profile={}{}", GONIO_VERSION_STRING,
                     text::format_number(o.rel_se), o.replicates, o.seed, profile,
                     profile_version ? fmt::format("#{}", profile_version) : std::string());
}

}  // namespace

twin::InstrumentProfile TwinService::profile() const {
  std::lock_guard lock(profile_mu_);
  return profile_;
}

std::int64_t TwinService::profile_version() const {
  std::lock_guard lock(profile_mu_);
  return profile_version_;
}

std::string TwinService::version() const {
  std::lock_guard lock(profile_mu_);
  return version_;
}

TwinService::Snapshot TwinService::snapshot() const {
  std::lock_guard lock(profile_mu_);
  return Snapshot{profile_, profile_version_, version_};
}

void TwinService::set_profile(twin::InstrumentProfile profile, std::int64_t version,
                              std::string calibrated_at) {
  std::lock_guard lock(profile_mu_);
  version_ = make_version(options_, profile.name, version);
  profile_ = std::move(profile);
  profile_version_ = version;
  calibrated_at_ = std::move(calibrated_at);
}

nlohmann::json TwinService::profile_info() const {
  std::lock_guard lock(profile_mu_);
  return nlohmann::json{{"name", profile_.name},
                        {"version", profile_version_},
                        {"calibrated_at", calibrated_at_.empty() ? nlohmann::json(nullptr)
                                                                 : nlohmann::json(calibrated_at_)}};
}

TwinService::TwinService(const Config& config, twin::InstrumentProfile profile)
    : profile_(std::move(profile)) {
  options_.rel_se = config.twin_rel_se;
  options_.max_samples = config.twin_max_samples;
  options_.replicates = config.twin_replicates;
  options_.seed = config.twin_seed;
  options_.validate();
  version_ = make_version(options_, profile_.name, 0);
  unsigned n = config.twin_threads ? config.twin_threads : std::thread::hardware_concurrency();
  n = std::max(1u, n);
  for (unsigned i = 0; i < n; ++i) workers_.emplace_back([this] { work(); });
}

TwinService::~TwinService() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  cv_.notify_all();
  for (auto& w : workers_) w.join();
}

void TwinService::post(std::function<void()> task) {
  {
    std::lock_guard lock(mu_);
    tasks_.push_back(std::move(task));
  }
  cv_.notify_one();
}

void TwinService::work() {
  for (;;) {
    std::function<void()> task;
    {
      std::unique_lock lock(mu_);
      cv_.wait(lock, [&] { return stopping_ || !tasks_.empty(); });
      if (stopping_) return;  // pending tasks are abandoned; their batches are cancelled
      task = std::move(tasks_.front());
      tasks_.pop_front();
    }
    task();
  }
}

std::size_t TwinService::queued() const {
  std::lock_guard lock(mu_);
  return tasks_.size();
}

std::shared_ptr<const twin::Twin> TwinService::make(const std::string& bsdf,
                                                    const WavelengthGrid& grid,
                                                    const std::string& field) const {
  return make(bsdf, grid, field, profile());
}

std::shared_ptr<const twin::Twin> TwinService::make(const std::string& bsdf,
                                                    const WavelengthGrid& grid,
                                                    const std::string& field,
                                                    const twin::InstrumentProfile& profile) const {
  try {
    return std::make_shared<const twin::Twin>(profile, twin::make_bsdf(bsdf, grid), grid);
  } catch (const Error& e) {
    // The twin names its fields "bsdf…"; put ours in their place ("sample.bsdf.lambert.albedo").
    if (field == "bsdf") throw;
    std::string f = e.field(), msg = e.what();
    if (f.starts_with("bsdf")) {
      f = field + f.substr(4);
      if (msg.starts_with("bsdf")) msg = field + msg.substr(4);
    } else {
      f = join_field(field, f);
      msg = fmt::format("{}: {}", field, msg);
    }
    throw Error(e.code(), msg, f);
  }
}

std::vector<twin::Prediction> TwinService::predict(const twin::Twin& twin,
                                                   const std::vector<Geometry>& geometries,
                                                   const twin::EstimatorOptions& options) {
  std::vector<std::future<twin::Prediction>> futures;
  futures.reserve(geometries.size());
  for (const auto& g : geometries) {
    auto task = std::make_shared<std::packaged_task<twin::Prediction()>>(
        [&twin, g, options] { return twin.predict(g, options); });
    futures.push_back(task->get_future());
    post([task] { (*task)(); });
  }
  std::vector<twin::Prediction> out;
  out.reserve(geometries.size());
  for (auto& f : futures) out.push_back(f.get());
  return out;
}

std::shared_ptr<TwinService::Batch> TwinService::batch(std::shared_ptr<const ScanTwin> twin,
                                                       std::vector<Geometry> geometries,
                                                       std::size_t first, std::size_t window) {
  if (window == 0) window = std::max<std::size_t>(8, 4 * workers_.size());
  return std::shared_ptr<Batch>(new Batch(*this, std::move(twin), std::move(geometries), first, window));
}

struct TwinService::Batch::State {
  struct Slot {
    bool done = false;
    std::optional<ScanTwin::PointPrediction> value;
    std::exception_ptr error;
  };
  std::mutex mu;
  std::condition_variable cv;
  std::deque<Slot> slots;      // slots[k] is geometry base + k
  std::size_t base = 0;
  std::size_t submitted = 0;   // geometries [0, submitted) are queued or done
  std::atomic<bool> cancelled{false};
};

TwinService::Batch::Batch(TwinService& pool, std::shared_ptr<const ScanTwin> twin,
                          std::vector<Geometry> geoms, std::size_t first, std::size_t window)
    : pool_(pool), twin_(std::move(twin)), geometries_(std::move(geoms)), window_(window),
      state_(std::make_shared<State>()) {
  std::lock_guard lock(state_->mu);
  state_->base = state_->submitted = first;
  submit_upto(first + window_);
}

TwinService::Batch::~Batch() { cancel(); }

void TwinService::Batch::cancel() {
  {
    std::lock_guard lock(state_->mu);
    state_->cancelled = true;
  }
  state_->cv.notify_all();
}

void TwinService::Batch::submit_upto(std::size_t end) {
  end = std::min(end, geometries_.size());
  auto& st = *state_;
  for (; st.submitted < end; ++st.submitted) {
    st.slots.emplace_back();
    pool_.post([state = state_, twin = twin_, g = geometries_[st.submitted],
                options = pool_.options_, i = st.submitted] {
      if (state->cancelled.load()) return;
      State::Slot result;
      try {
        result.value = twin->predict(g, options);
      } catch (...) {
        result.error = std::current_exception();
      }
      std::lock_guard lock(state->mu);
      if (i < state->base || i - state->base >= state->slots.size()) return;
      auto& slot = state->slots[i - state->base];
      slot = std::move(result);
      slot.done = true;
      state->cv.notify_all();
    });
  }
}

ScanTwin::PointPrediction TwinService::Batch::wait(std::size_t i) {
  auto& st = *state_;
  std::unique_lock lock(st.mu);
  if (i < st.base || i >= geometries_.size())
    throw Error(Errc::internal, fmt::format("prediction {} requested out of order", i));
  // Free what the runner has moved past, then look further ahead.
  while (st.base < i) {
    if (!st.slots.empty()) st.slots.pop_front();
    ++st.base;
  }
  if (st.submitted < st.base) st.submitted = st.base;
  submit_upto(i + 1 + window_);
  st.cv.wait(lock, [&] { return st.slots.front().done || st.cancelled.load(); });
  if (!st.slots.front().done) throw Error::wrong_state("", "prediction cancelled");
  if (st.slots.front().error) std::rethrow_exception(st.slots.front().error);
  return *st.slots.front().value;
}

}  // namespace gonio::daemon
