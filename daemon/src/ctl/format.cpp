// Text output of gonioctl: tables, progress bars, durations (see ctl.hpp).
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "gonio/daemon/ctl/ctl.hpp"
#include "gonio/daemon/rpc/rpc.hpp"

namespace gonio::daemon {
namespace {

// Display width of UTF-8 text (code points; enough for the symbols gonioctl prints).
std::size_t width(const std::string& s) {
  std::size_t n = 0;
  for (unsigned char c : s)
    if ((c & 0xC0) != 0x80) ++n;
  return n;
}

bool numeric(const std::string& s) {
  if (s.empty()) return false;
  char* end = nullptr;
  (void)std::strtod(s.c_str(), &end);
  return end && *end == '\0';
}

}  // namespace

int exit_code_for_rpc(int code) noexcept {
  switch (code) {
    case rpc::code::parse_error:
    case rpc::code::invalid_request:
    case rpc::code::method_not_found:
    case rpc::code::invalid_params: return ctl_exit::usage;
    case rpc::code::internal_error: return ctl_exit::internal;
    case rpc::code::unauthorized:
    case rpc::code::forbidden: return ctl_exit::auth;
    case rpc::code::not_found: return ctl_exit::not_found;
    case rpc::code::invalid_state:
    case rpc::code::instrument_busy: return ctl_exit::state;
    case rpc::code::instrument_fault:
    case rpc::code::limit_violation: return ctl_exit::instrument;
    case rpc::code::plan_rejected: return ctl_exit::plan;
    default: return ctl_exit::server;
  }
}

std::string Table::render() const {
  const std::size_t cols = header_.size();
  std::vector<std::size_t> w(cols, 0);
  std::vector<bool> right(cols, true);
  for (std::size_t c = 0; c < cols; ++c) w[c] = width(header_[c]);
  for (const auto& r : rows_)
    for (std::size_t c = 0; c < cols && c < r.size(); ++c) {
      w[c] = std::max(w[c], width(r[c]));
      if (!r[c].empty() && r[c] != "-" && !numeric(r[c])) right[c] = false;
    }
  const auto line = [&](const std::vector<std::string>& r) {
    std::string out;
    for (std::size_t c = 0; c < cols; ++c) {
      const std::string v = c < r.size() ? r[c] : "";
      const std::string pad(w[c] - std::min(w[c], width(v)), ' ');
      if (c) out += "  ";
      out += right[c] ? pad + v : (c + 1 == cols ? v : v + pad);
    }
    while (!out.empty() && out.back() == ' ') out.pop_back();
    return out + "\n";
  };
  std::string out = line(header_);
  for (const auto& r : rows_) out += line(r);
  return out;
}

std::string format_duration(double s) {
  if (!std::isfinite(s) || s < 0) return "-";
  const auto t = static_cast<long long>(std::llround(s));
  if (t >= 3600) return fmt::format("{}:{:02}:{:02}", t / 3600, (t / 60) % 60, t % 60);
  return fmt::format("{}:{:02}", t / 60, t % 60);
}

std::string progress_bar(std::size_t done, std::size_t total, double eta_s, std::size_t diverged,
                         int bar) {
  const double f = total ? std::min(1.0, static_cast<double>(done) / static_cast<double>(total)) : 0.0;
  const int filled = static_cast<int>(std::floor(f * bar + 1e-9));
  std::string b = "[";
  for (int i = 0; i < bar; ++i) b += i < filled ? "#" : "·";
  b += "]";
  return fmt::format("{} {:>{}}/{}  {:3.0f} %  ETA {}  diverged {}", b, done,
                     fmt::formatted_size("{}", total), total, 100 * f,
                     done >= total ? "0:00" : format_duration(eta_s), diverged);
}

std::string cell(const nlohmann::json& v) {
  if (v.is_null()) return "-";
  if (v.is_string()) return v.get<std::string>();
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  if (v.is_number_integer()) return std::to_string(v.get<long long>());
  if (v.is_number()) {
    const double d = v.get<double>();
    return fmt::format("{:.4g}", d);
  }
  return v.dump();
}

}  // namespace gonio::daemon
