// The auto-ranging loop of a point's readings (auto_ranger.hpp); the rule is autorange.cpp.
#include "gonio/daemon/instrument/auto_ranger.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/proto/error.hpp"

namespace gonio::daemon {

using drivers::Channel;

AutoRanger::AutoRanger(Settings s, std::function<void()> beat) : s_(std::move(s)), beat_(std::move(beat)) {}

double AutoRanger::nominal_ms(drivers::Photometer& p) {
  if (!s_.enabled || !p.capabilities().settable_integration) return 0;
  if (!nominal_) {
    // The configured setting, else the photometer's own as goniod first finds it (kept, so
    // that a setting left short by ranging is not taken for the nominal one).
    beat_();
    nominal_ = s_.integration_ms ? *s_.integration_ms : p.integration_ms(s_.timeout);
  }
  return std::clamp(*nominal_, s_.limits.min_ms, s_.limits.max_ms);
}

void AutoRanger::set(drivers::Photometer& p, double ms) {
  if (set_ && std::abs(*set_ - ms) <= 1e-9 * ms) return;
  set_.reset();  // unknown until the device took it
  beat_();
  p.set_integration_ms(ms, s_.timeout);
  set_ = ms;
}

PointReadings AutoRanger::read(drivers::Photometer& p, double nominal_ms, bool reference_due,
                               ReferenceReadings& ref, const std::string& what) {
  PointReadings in;
  const bool ranging = nominal_ms > 0;
  const auto measure = [&](Channel ch, drivers::SaturationPolicy policy) {
    beat_();
    return p.measure(ch, s_.timeout, policy);
  };
  const auto policy = ranging ? drivers::SaturationPolicy::flag : drivers::SaturationPolicy::throw_error;
  double t = nominal_ms;
  std::optional<double> ceiling;
  std::optional<double> kept;  // the setting of the readings in hand, while ranging further
  for (;;) {
    if (ranging) {
      try {
        set(p, t);
      } catch (const Error& e) {
        // The photometer's own limits are narrower than the configured ones.
        if (e.code() != Errc::out_of_range) throw;
        if (ceiling && t < *ceiling)
          throw Error(Errc::saturated,
                      fmt::format("detector saturated at {:g} ms and the photometer refuses a shorter "
                                  "integration time ({}); attenuate the beam",
                                  *ceiling, e.what()));
        if (!kept) throw;
        t = *kept;  // a longer setting refused: keep the readings at the last one
        set_.reset();
        break;
      }
    }
    in.dark = measure(Channel::dark, drivers::SaturationPolicy::throw_error);
    const bool ref_stale = ranging && ref.white && ref.white->integration_ms > 0 &&
                           std::abs(ref.white->integration_ms - t) > 1e-9 * t;
    if (reference_due || ref_stale) {
      ref.white = measure(Channel::reference, policy);
      ref.dark = in.dark;
      in.read_reference = true;
    }
    in.sample = measure(Channel::sample, policy);
    if (!ranging) break;
    const bool saturated = in.sample.saturated || ref.white->saturated;
    const auto next =
        next_integration_ms(t, saturated, saturated ? 0 : best_channel_snr(in.sample, in.dark), ceiling, s_.limits);
    if (!next) {
      if (saturated) {
        // The shortest setting still saturates: only now a fault, naming the channel.
        throw Error(Errc::saturated,
                    fmt::format("detector saturated on the {} channel at {:g} ms, the shortest "
                                "integration time allowed (instrument.integration_min_ms); "
                                "attenuate the beam",
                                ref.white->saturated ? "reference" : "sample", t));
      }
      break;
    }
    if (saturated) ceiling = t;
    else kept = t;
    spdlog::debug("{}: {} at {:g} ms; reading again at {:g} ms", what, saturated ? "saturated" : "under-exposed",
                  t, *next);
    t = *next;
  }
  in.integration_ms = in.sample.integration_ms > 0 ? in.sample.integration_ms : ranging ? t : 0;
  return in;
}

}  // namespace gonio::daemon
