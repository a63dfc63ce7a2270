// The SCPI photometer driver: one Photometer over a SCPI Session, with the `gonio` preset
// (proto/scpi-gonio.md: a whole spectrum with per-channel uncertainty in one reply) and the
// `pm100` preset (Thorlabs PM100-class power meters: SENS:CORR:WAV <nm> then MEAS:POW?,
// one wavelength at a time, `repeats` readings per wavelength for mean and standard error).
#include <cmath>
#include <mutex>
#include <type_traits>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "gonio/drivers/scpi/scpi.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio::drivers::scpi {
namespace {

const char* channel_keyword(Channel c) {
  switch (c) {
    case Channel::sample: return "SAMP";
    case Channel::reference: return "REF";
    case Channel::dark: return "DARK";
  }
  return "SAMP";
}

class ScpiPhotometer final : public Photometer {
 public:
  ScpiPhotometer(TransportPtr t, PhotometerConfig c)
      : cfg_(std::move(c)), session_(std::move(t), SessionOptions{}) {
    if (cfg_.preset == Preset::pm100 && !cfg_.wavelengths)
      throw Error::invalid("wavelengths", "the pm100 preset needs the wavelengths to read");
  }

  PhotometerCapabilities capabilities() const override {
    PhotometerCapabilities c;
    if (cfg_.preset == Preset::gonio) {
      c.dual_beam = true;
      c.dark_shutter = true;
      c.settable_integration = true;
      c.uncertainty_from_device = true;
    }
    return c;
  }

  Identity identify(milliseconds timeout) override {
    return in_step([&] { return parse_identity(session_.query("*IDN?", deadline_after(timeout))); });
  }

  WavelengthGrid wavelengths(milliseconds timeout) override {
    return in_step([&] { return read_wavelengths(timeout); });
  }

  double integration_ms(milliseconds timeout) override {
    return in_step([&] { return read_integration_ms(timeout); });
  }

  void set_integration_ms(double ms, milliseconds timeout) override {
    in_step([&] { write_integration_ms(ms, timeout); });
  }

  Reading measure(Channel ch, milliseconds timeout, SaturationPolicy policy) override {
    const auto d = deadline_after(timeout);
    Reading r = in_step(
        [&] { return cfg_.preset == Preset::gonio ? measure_gonio(ch, d) : measure_pm100(ch, d); });
    check_saturation(r, policy);
    return r;
  }

  void cancel() noexcept override { session_.cancel(); }

 private:
  // A reply that breaks the protocol may have been a late reply to an earlier query, and
  // then this query's reply is still coming: the session resynchronises before the next.
  template <typename F>
  std::invoke_result_t<F> in_step(F&& f) {
    try {
      return f();
    } catch (const Error& e) {
      if (e.code() == Errc::protocol_error) session_.mark_out_of_step();
      throw;
    }
  }

  WavelengthGrid read_wavelengths(milliseconds timeout) {
    if (cfg_.wavelengths) return *cfg_.wavelengths;
    const auto d = deadline_after(timeout);
    const auto nm = parse_numbers(session_.query("SENS:WAV:DATA?", d), "wavelength list",
                                  WavelengthGrid::kMaxChannels);
    try {
      cfg_.wavelengths = WavelengthGrid(nm, "device wavelengths");
    } catch (const Error& e) {
      throw Error(Errc::protocol_error, fmt::format("{}: {}", session_.transport().describe(), e.what()));
    }
    return *cfg_.wavelengths;
  }

  double read_integration_ms(milliseconds timeout) {
    if (cfg_.preset == Preset::pm100) return 0;
    return 1000 * parse_number(session_.query("SENS:INT:TIME?", deadline_after(timeout)),
                               "integration time");
  }

  void write_integration_ms(double ms, milliseconds timeout) {
    if (cfg_.preset == Preset::pm100)
      throw Error(Errc::unsupported, "the pm100 preset has no settable integration time");
    const auto d = deadline_after(timeout);
    if (!limits_) {
      const double lo = parse_number(session_.query("SENS:INT:TIME? MIN", d), "integration time");
      const double hi = parse_number(session_.query("SENS:INT:TIME? MAX", d), "integration time");
      limits_ = {1000 * lo, 1000 * hi};
    }
    if (!(ms >= limits_->first && ms <= limits_->second))
      throw Error::out_of_range("integration_ms", ms, limits_->first, limits_->second, " ms");
    const auto cmd = fmt::format("SENS:INT:TIME {:.9g}", ms / 1000);
    session_.command(cmd, d);
    if (cfg_.check_errors) session_.check_errors(cmd, d);
  }

  Reading measure_gonio(Channel ch, Deadline d) {
    const auto grid = read_wavelengths(remaining(d));
    const auto n = grid.size();
    const auto v = parse_numbers(session_.query(fmt::format("MEAS:SPEC? {}", channel_keyword(ch)), d),
                                 "spectrum reply", 3 + 2 * WavelengthGrid::kMaxChannels);
    const auto fail = [&](std::string why) {
      throw Error(Errc::protocol_error,
                  fmt::format("{}: MEAS:SPEC? reply: {}", session_.transport().describe(), why));
    };
    if (v.size() < 3) fail(fmt::format("{} values, expected at least 3", v.size()));
    if (v[0] != 0 && v[0] != 1) fail("saturation flag is not 0 or 1");
    if (!(v[1] >= 0) || !std::isfinite(v[1])) fail("integration time is not a time");
    if (v[2] != static_cast<double>(n))
      fail(fmt::format("{} channels, the device lists {} wavelengths", v[2], n));
    if (v.size() != 3 + 2 * n) fail(fmt::format("{} values, expected {}", v.size(), 3 + 2 * n));
    Reading r;
    r.channel = ch;
    r.unit = "counts";
    r.saturated = v[0] == 1;
    r.integration_ms = 1000 * v[1];
    std::vector<double> val(v.begin() + 3, v.begin() + 3 + static_cast<std::ptrdiff_t>(n));
    std::vector<double> unc(v.begin() + 3 + static_cast<std::ptrdiff_t>(n), v.end());
    for (std::size_t i = 0; i < n; ++i)
      if (!std::isfinite(val[i]) || !std::isfinite(unc[i]) || unc[i] < 0)
        fail(fmt::format("channel {} ({} nm) is not a finite value with uncertainty >= 0", i, grid[i]));
    r.spectrum = Spectrum(grid, std::move(val), std::move(unc));
    return r;
  }

  Reading measure_pm100(Channel ch, Deadline d) {
    if (!configured_) {
      if (cfg_.averages > 0) {
        const auto cmd = fmt::format("SENS:AVER:COUN {}", cfg_.averages);
        session_.command(cmd, d);
        if (cfg_.check_errors) session_.check_errors(cmd, d);
      }
      configured_ = true;
    }
    const auto& grid = *cfg_.wavelengths;
    Reading r;
    r.channel = ch;
    r.unit = "W";
    std::vector<double> val(grid.size()), unc(grid.size());
    for (std::size_t i = 0; i < grid.size(); ++i) {
      const auto cmd = fmt::format("SENS:CORR:WAV {:g}", grid[i]);
      session_.command(cmd, d);
      if (cfg_.check_errors) session_.check_errors(cmd, d);
      double sum = 0, sum2 = 0;
      for (int k = 0; k < cfg_.repeats; ++k) {
        const double p = parse_number(session_.query("MEAS:POW?", d), "power reading");
        if (!std::isfinite(p)) {  // 9.9E37 / 9.91E37: over range
          r.saturated = true;
          break;
        }
        sum += p;
        sum2 += p * p;
      }
      const double m = cfg_.repeats;
      val[i] = r.saturated ? 0 : sum / m;
      if (cfg_.repeats > 1 && !r.saturated) {
        const double var = std::max(0.0, (sum2 - sum * sum / m) / (m - 1));
        unc[i] = std::sqrt(var / m);
      }
      if (r.saturated) break;
    }
    r.spectrum = Spectrum(grid, std::move(val), std::move(unc));
    return r;
  }

  PhotometerConfig cfg_;
  Session session_;
  std::optional<std::pair<double, double>> limits_;  // integration time, ms
  bool configured_ = false;
};

}  // namespace

PhotometerConfig PhotometerConfig::read(json_util::ObjectReader& r) {
  PhotometerConfig c;
  c.preset = parse_enum<Preset>(r.optional<std::string>("preset", "gonio"), r.path("preset"));
  if (const auto* w = r.raw("wavelengths"); w != nullptr && !w->is_null()) {
    if (w->is_string())
      c.wavelengths = WavelengthGrid::parse(w->get<std::string>(), r.path("wavelengths"));
    else
      c.wavelengths = json_util::get_as<WavelengthGrid>(*w, r.path("wavelengths"));
  }
  c.repeats = r.optional_in("repeats", c.repeats, 1, 1000);
  c.averages = r.optional_in("averages", c.averages, 0, 100000);
  c.check_errors = r.optional<bool>("check_errors", c.check_errors);
  c.open_timeout = std::chrono::milliseconds(r.optional_in<long long>("open_timeout_ms", 5000, 1, 600000, " ms"));
  if (c.preset == Preset::pm100 && !c.wavelengths)
    throw Error::invalid(r.path("wavelengths"), "is required for the pm100 preset");
  return c;
}

std::unique_ptr<Photometer> make_photometer(TransportPtr transport, PhotometerConfig config) {
  return std::make_unique<ScpiPhotometer>(std::move(transport), std::move(config));
}

std::unique_ptr<Photometer> make_photometer(std::string_view transport_type,
                                            const nlohmann::json& config) {
  // No context of its own: the registry names the side ("photometer.baud").
  json_util::ObjectReader r(config, "");
  auto pc = PhotometerConfig::read(r);
  auto transport = read_transport(transport_type, r);
  r.finish();
  return make_photometer(transport.open(), std::move(pc));
}

DeviceRef check_photometer(std::string_view transport_type, const nlohmann::json& config) {
  // No context of its own: the registry names the side ("photometer.baud").
  json_util::ObjectReader r(config, "");
  (void)PhotometerConfig::read(r);
  auto transport = read_transport(transport_type, r);
  r.finish();
  return transport.device;
}

}  // namespace gonio::drivers::scpi
