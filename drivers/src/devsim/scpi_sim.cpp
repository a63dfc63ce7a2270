// ScpiSimDevice — the command interpreter of the simulated photometer. Header matching
// follows SCPI-1999 Vol. 1 §6.2 (short/long keyword forms, case-insensitive, optional nodes
// in brackets, ';' separating commands of one program message, a leading ':' for the root);
// errors go to a 10-entry queue read by SYST:ERR? (Vol. 2 §21.8; -350 on overflow).
#include "gonio/sim/devsim/scpi_sim.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <utility>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"

namespace gonio::drivers::devsim {
namespace {

struct Node {
  std::string long_form;  // e.g. "INTegration"
  bool optional = false;
};

std::vector<Node> parse_pattern(std::string_view p) {
  std::vector<Node> nodes;
  std::size_t i = 0;
  while (i < p.size()) {
    bool opt = false;
    if (p[i] == '[') {
      opt = true;
      ++i;
    }
    if (i < p.size() && p[i] == ':') ++i;
    std::string kw;
    while (i < p.size() && p[i] != ':' && p[i] != '[' && p[i] != ']') kw += p[i++];
    if (i < p.size() && p[i] == ']') ++i;
    nodes.push_back({kw, opt});
  }
  return nodes;
}

std::string upper(std::string_view s) {
  std::string out(s);
  for (auto& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

bool keyword_matches(const std::string& long_form, std::string_view kw) {
  std::string short_form;
  for (const char c : long_form)
    if (std::isupper(static_cast<unsigned char>(c)) || c == '*' || c == '?' || std::isdigit(static_cast<unsigned char>(c)))
      short_form += c;
  const auto k = upper(kw);
  return k == upper(long_form) || k == short_form;
}

bool match_nodes(const std::vector<Node>& p, std::size_t pi, const std::vector<std::string>& h,
                 std::size_t hi) {
  if (pi == p.size()) return hi == h.size();
  if (hi < h.size() && keyword_matches(p[pi].long_form, h[hi]) && match_nodes(p, pi + 1, h, hi + 1))
    return true;
  return p[pi].optional && match_nodes(p, pi + 1, h, hi);
}

// "SENS:INT:TIME?" against "[SENSe]:INTegration:TIME?"
bool matches(std::string_view pattern, std::string_view header) {
  const bool pq = !pattern.empty() && pattern.back() == '?';
  const bool hq = !header.empty() && header.back() == '?';
  if (pq != hq) return false;
  if (pq) {
    pattern.remove_suffix(1);
    header.remove_suffix(1);
  }
  if (!header.empty() && header.front() == ':') header.remove_prefix(1);
  std::vector<std::string> h;
  std::size_t start = 0;
  for (;;) {
    const auto c = header.find(':', start);
    h.emplace_back(header.substr(start, c - start));
    if (c == std::string_view::npos) break;
    start = c + 1;
  }
  for (const auto& k : h)
    if (k.empty()) return false;
  return match_nodes(parse_pattern(pattern), 0, h, 0);
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

std::optional<double> number(std::string_view s) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double v = 0;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc() || p != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::string fmt_num(double v) { return fmt::format("{:.7E}", v); }

// Thrown inside execute() to queue a SCPI error.
struct ScpiError {
  int code;
  std::string text;
};

}  // namespace

ScpiSimConfig ScpiSimConfig::from_json(const nlohmann::json& j) {
  ScpiSimConfig c;
  json_util::ObjectReader r(j, "photometer");
  c.preset = r.optional<std::string>("preset", c.preset);
  if (c.preset != "gonio" && c.preset != "pm100")
    throw Error::invalid(r.path("preset"), fmt::format("'{}' (allowed: gonio, pm100)", c.preset));
  if (r.has("identity")) {
    const auto id = r.required<std::string>("identity");
    std::vector<std::string> f;
    std::size_t s = 0;
    for (;;) {
      const auto k = id.find(',', s);
      f.push_back(id.substr(s, k - s));
      if (k == std::string::npos) break;
      s = k + 1;
    }
    if (f.size() != 4) throw Error::invalid(r.path("identity"), "expected manufacturer,model,serial,firmware");
    c.identity = {f[0], f[1], f[2], f[3]};
  }
  if (r.has("wavelengths"))
    c.wavelengths = WavelengthGrid::parse(r.required<std::string>("wavelengths"), r.path("wavelengths"));
  const auto num = [&](const char* key, double& v, double lo, double hi) { v = r.optional_in(key, v, lo, hi); };
  num("min_integration_ms", c.min_integration_ms, 0.01, 1e6);
  num("max_integration_ms", c.max_integration_ms, c.min_integration_ms, 1e6);
  num("integration_ms", c.integration_ms, c.min_integration_ms, c.max_integration_ms);
  num("gain_counts_per_ms", c.gain_counts_per_ms, 0, 1e9);
  num("dark_counts_per_ms", c.dark_counts_per_ms, 0, 1e9);
  num("read_noise_counts", c.read_noise_counts, 0, 1e9);
  num("full_scale_counts", c.full_scale_counts, 1, 1e15);
  num("pm100_watts", c.pm100_watts, 0, 1e3);
  c.seed = r.optional<std::uint64_t>("seed", c.seed);
  c.late_reply_at = r.optional_in("late_reply_at", c.late_reply_at, 0, 1000000000);
  num("late_reply_ms", c.late_reply_ms, 0, 600000);
  if (r.has("geometry")) c.geometry = Geometry::parse(r.required<std::string>("geometry"));
  c.geometry.validate(r.path("geometry"));
  r.finish();
  return c;
}

ScpiSimDevice::ScpiSimDevice(ScpiSimConfig config, BetaSource beta)
    : cfg_(std::move(config)), beta_(std::move(beta)), rng_(cfg_.seed) {}

std::chrono::milliseconds ScpiSimDevice::take_reply_delay() {
  std::lock_guard lock(mu_);
  return std::exchange(reply_delay_, std::chrono::milliseconds(0));
}

void ScpiSimDevice::push_error(int code, std::string_view text) {
  if (errors_.size() >= 10) {  // SCPI-1999 Vol. 2 §21.8.2: the last entry becomes -350
    errors_.back() = {-350, "Queue overflow"};
    return;
  }
  errors_.emplace_back(code, std::string(text));
}

std::string ScpiSimDevice::handle(std::string_view message) {
  std::lock_guard lock(mu_);
  std::string response;
  std::size_t start = 0;
  for (;;) {
    const auto semi = message.find(';', start);
    const auto cmd = trim(message.substr(start, semi - start));
    if (!cmd.empty()) {
      try {
        auto r = execute(cmd);
        if (!r.empty()) response += (response.empty() ? "" : ";") + r;
      } catch (const ScpiError& e) {
        push_error(e.code, e.text);
      } catch (const Error& e) {  // the BetaSource failed: a device-specific error
        push_error(-240, fmt::format("Hardware error; {}", e.what()).substr(0, 200));
      }
    }
    if (semi == std::string_view::npos) break;
    start = semi + 1;
  }
  return response;
}

std::string ScpiSimDevice::execute(std::string_view command) {
  const auto sp = command.find_first_of(" \t");
  const auto header = command.substr(0, sp);
  const auto arg = sp == std::string_view::npos ? std::string_view{} : trim(command.substr(sp));
  const auto no_arg = [&] {
    if (!arg.empty()) throw ScpiError{-108, "Parameter not allowed"};
  };
  const bool pm = cfg_.preset == "pm100";

  if (matches("*IDN?", header)) {
    no_arg();
    const auto& id = cfg_.identity;
    return fmt::format("{},{},{},{}", id.manufacturer, id.model, id.serial, id.firmware);
  }
  if (matches("*RST", header) || matches("*CLS", header)) {
    no_arg();
    if (matches("*CLS", header)) errors_.clear();
    return {};
  }
  if (matches("*OPC?", header)) return "1";
  if (matches("SYSTem:ERRor[:NEXT]?", header)) {
    no_arg();
    if (errors_.empty()) return "0,\"No error\"";
    auto [code, text] = errors_.front();
    errors_.pop_front();
    std::string escaped;
    for (const char c : text) escaped += c == '"' ? std::string("\"\"") : std::string(1, c);
    return fmt::format("{},\"{}\"", code, escaped);
  }
  if (matches("SYSTem:VERSion?", header)) return "1999.0";
  if (matches("SIMulation:GEOMetry", header)) {
    const auto v = [&] {
      std::vector<double> out;
      std::size_t s = 0;
      for (;;) {
        const auto c = arg.find(',', s);
        const auto n = number(arg.substr(s, c - s));
        if (!n) throw ScpiError{-224, "Illegal parameter value"};
        out.push_back(*n);
        if (c == std::string_view::npos) break;
        s = c + 1;
      }
      return out;
    }();
    if (v.size() != 2 && v.size() != 4) throw ScpiError{-109, "Missing parameter"};
    Geometry g{v[0], v.size() == 4 ? v[2] : 0, v[1], v.size() == 4 ? v[3] : 0};
    try {
      g.validate();
    } catch (const Error&) {
      throw ScpiError{-222, "Data out of range"};
    }
    cfg_.geometry = g;
    return {};
  }
  if (matches("SIMulation:GEOMetry?", header))
    return fmt::format("{:g},{:g},{:g},{:g}", cfg_.geometry.theta_i, cfg_.geometry.theta_r,
                       cfg_.geometry.phi_i, cfg_.geometry.phi_r);

  if (!pm) {
    if (matches("SYSTem:PROTocol:VERSion?", header)) return "1.0";
    if (matches("[SENSe]:WAVelength:COUNt?", header)) return std::to_string(cfg_.wavelengths.size());
    if (matches("[SENSe]:WAVelength:DATA?", header)) {
      std::string out;
      for (const double nm : cfg_.wavelengths) out += (out.empty() ? "" : ",") + fmt::format("{:g}", nm);
      return out;
    }
    if (matches("[SENSe]:INTegration:TIME?", header)) {
      const auto a = upper(arg);
      if (a.empty()) return fmt_num(cfg_.integration_ms / 1000);
      if (a == "MIN" || a == "MINIMUM") return fmt_num(cfg_.min_integration_ms / 1000);
      if (a == "MAX" || a == "MAXIMUM") return fmt_num(cfg_.max_integration_ms / 1000);
      throw ScpiError{-224, "Illegal parameter value"};
    }
    if (matches("[SENSe]:INTegration:TIME", header)) {
      const auto a = upper(arg);
      double ms = 0;
      if (a.empty()) throw ScpiError{-109, "Missing parameter"};
      if (a == "MIN" || a == "MINIMUM") ms = cfg_.min_integration_ms;
      else if (a == "MAX" || a == "MAXIMUM") ms = cfg_.max_integration_ms;
      else if (const auto s = number(arg)) ms = *s * 1000;
      else throw ScpiError{-104, "Data type error"};
      if (ms < cfg_.min_integration_ms * (1 - 1e-9) || ms > cfg_.max_integration_ms * (1 + 1e-9))
        throw ScpiError{-222, "Data out of range"};
      cfg_.integration_ms = ms;
      return {};
    }
    if (matches("MEASure:SPECtrum?", header)) {
      count_measurement();
      return measure_spectrum(arg);
    }
  } else {
    if (matches("[SENSe]:CORRection:WAVelength", header)) {
      const auto nm = number(arg);
      if (!nm) throw ScpiError{arg.empty() ? -109 : -104, arg.empty() ? "Missing parameter" : "Data type error"};
      if (*nm < cfg_.wavelengths.values().front() || *nm > cfg_.wavelengths.values().back())
        throw ScpiError{-222, "Data out of range"};
      pm_wavelength_ = *nm;
      return {};
    }
    if (matches("[SENSe]:CORRection:WAVelength?", header)) return fmt_num(pm_wavelength_);
    if (matches("[SENSe]:AVERage[:COUNt]", header)) {
      const auto n = number(arg);
      if (!n || *n < 1 || *n > 100000) throw ScpiError{-222, "Data out of range"};
      pm_averages_ = static_cast<int>(*n);
      return {};
    }
    if (matches("MEASure[:SCALar]:POWer?", header)) {
      count_measurement();
      return measure_power();
    }
  }
  throw ScpiError{-113, "Undefined header"};
}

std::string ScpiSimDevice::measure_spectrum(std::string_view arg) {
  const auto a = upper(arg);
  double scale = 0;  // β multiplier: sample β, reference 1, dark 0
  std::vector<double> beta;
  if (a == "SAMP" || a == "SAMPLE") {
    beta = beta_(cfg_.geometry);
    scale = 1;
  } else if (a == "REF" || a == "REFERENCE") {
    beta.assign(cfg_.wavelengths.size(), 1.0);
    scale = 1;
  } else if (a == "DARK") {
    beta.assign(cfg_.wavelengths.size(), 0.0);
  } else if (a.empty()) {
    throw ScpiError{-109, "Missing parameter"};
  } else {
    throw ScpiError{-224, "Illegal parameter value"};
  }
  if (beta.size() != cfg_.wavelengths.size()) throw ScpiError{-240, "Hardware error; model channel count"};
  const double t = cfg_.integration_ms;
  const std::size_t n = beta.size();
  std::vector<double> val(n), unc(n);
  bool saturated = false;
  std::normal_distribution<double> gauss(0, 1);
  for (std::size_t i = 0; i < n; ++i) {
    const double mean = cfg_.dark_counts_per_ms * t + scale * cfg_.gain_counts_per_ms * t * std::max(0.0, beta[i]);
    const double sd = std::sqrt(mean + cfg_.read_noise_counts * cfg_.read_noise_counts);
    double v = mean + sd * gauss(rng_);
    if (v >= cfg_.full_scale_counts) {
      v = cfg_.full_scale_counts;
      saturated = true;
    }
    val[i] = std::max(0.0, v);
    unc[i] = sd;
  }
  std::string out = fmt::format("{},{},{}", saturated ? 1 : 0, fmt_num(t / 1000), n);
  for (const double v : val) out += "," + fmt_num(v);
  for (const double u : unc) out += "," + fmt_num(u);
  return out;
}

void ScpiSimDevice::count_measurement() {
  if (++measurements_ == cfg_.late_reply_at)
    reply_delay_ = std::chrono::milliseconds(static_cast<long long>(cfg_.late_reply_ms));
}

std::string ScpiSimDevice::measure_power() {
  const auto beta = beta_(cfg_.geometry);
  std::vector<double> nm = cfg_.wavelengths.values();
  const double b = interpolate_linear(nm, beta, {pm_wavelength_}).front();
  const double mean = cfg_.pm100_watts * std::max(0.0, b);
  std::normal_distribution<double> gauss(0, 1);
  const double sd = 1e-3 * mean / std::sqrt(static_cast<double>(pm_averages_)) + 1e-12;
  const double p = mean + sd * gauss(rng_);
  if (p > 1.0) return "9.9E37";  // over range
  return fmt_num(p);
}

}  // namespace gonio::drivers::devsim
