#include "gonio/proto/text.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio::text {

std::string_view trim(std::string_view s) noexcept {
  const auto* ws = " \t\r\n";
  const auto b = s.find_first_not_of(ws);
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(ws);
  return s.substr(b, e - b + 1);
}

std::vector<std::string_view> split(std::string_view s, char sep) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (;;) {
    const auto pos = s.find(sep, start);
    out.push_back(s.substr(start, pos == std::string_view::npos ? s.npos : pos - start));
    if (pos == std::string_view::npos) break;
    start = pos + 1;
  }
  return out;
}

double parse_double(std::string_view field, std::string_view s) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc{} || ptr != s.data() + s.size() || !std::isfinite(v))
    throw Error::invalid(std::string(field), fmt::format("'{}' is not a number", s));
  return v;
}

long long parse_int(std::string_view field, std::string_view s) {
  s = trim(s);
  long long v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc{} || ptr != s.data() + s.size())
    throw Error::invalid(std::string(field), fmt::format("'{}' is not an integer", s));
  return v;
}

std::vector<double> parse_value_list(std::string_view field, std::string_view s,
                                     std::size_t max_count) {
  std::vector<double> out;
  if (trim(s).empty()) throw Error::invalid(std::string(field), "empty list");
  for (auto item : split(s, ',')) {
    item = trim(item);
    const auto parts = split(item, ':');
    if (parts.size() == 1) {
      out.push_back(parse_double(field, item));
    } else if (parts.size() == 3) {
      const double a = parse_double(field, parts[0]);
      const double b = parse_double(field, parts[1]);
      const double step = parse_double(field, parts[2]);
      if (step <= 0)
        throw Error::invalid(std::string(field),
                             fmt::format("range '{}' needs a positive step", item));
      if (b < a)
        throw Error::invalid(std::string(field),
                             fmt::format("range '{}' has stop below start", item));
      const double n = std::floor((b - a) / step + 1e-9);
      if (n + 1 + static_cast<double>(out.size()) > static_cast<double>(max_count))
        throw Error::invalid(std::string(field),
                             fmt::format("more than {} values", max_count));
      for (long long k = 0; k <= static_cast<long long>(n); ++k)
        // Rounded to 1e-9 so that 0.1 steps print as typed, not as 0.30000000000000004.
        out.push_back(std::round((a + static_cast<double>(k) * step) * 1e9) / 1e9);
    } else {
      throw Error::invalid(std::string(field),
                           fmt::format("'{}' is neither a number nor start:stop:step", item));
    }
    if (out.size() > max_count)
      throw Error::invalid(std::string(field), fmt::format("more than {} values", max_count));
  }
  return out;
}

std::string format_number(double v) {
  if (v == 0) return "0";
  return fmt::format("{}", v);
}

std::string format_value_list(const std::vector<double>& values) {
  std::string out;
  std::size_t i = 0;
  const auto append = [&out](const std::string& s) {
    if (!out.empty()) out += ',';
    out += s;
  };
  while (i < values.size()) {
    std::size_t j = i + 1;
    if (j < values.size()) {
      const double step = values[j] - values[i];
      while (step > 0 && j + 1 < values.size() &&
             std::abs((values[j + 1] - values[j]) - step) <= 1e-9 * std::max(1.0, std::abs(step)))
        ++j;
      if (step > 0 && j - i >= 2) {
        append(format_number(values[i]) + ":" + format_number(values[j]) + ":" +
               format_number(step));
        i = j + 1;
        continue;
      }
    }
    append(format_number(values[i]));
    ++i;
  }
  return out;
}

std::string format_measured(double value, double u) {
  if (!std::isfinite(value)) return fmt::format("{}", value);
  if (!(u > 0) || !std::isfinite(u)) return fmt::format("{:.6g}", value);
  // The decimal place of u's second significant digit, after rounding (9.96 → 10).
  int place = static_cast<int>(std::floor(std::log10(u))) - 1;
  if (std::round(u / std::pow(10.0, place)) >= 100) ++place;
  const int value_exp = value == 0 ? place + 1 : static_cast<int>(std::floor(std::log10(std::abs(value))));
  if (place >= -6 && value_exp < 7) {
    if (place >= 0) {  // an integer: round both to that place
      const double scale = std::pow(10.0, place);
      return fmt::format("{:.0f} ± {:.0f}", std::round(value / scale) * scale, std::round(u / scale) * scale);
    }
    return fmt::format("{:.{}f} ± {:.{}f}", value, -place, u, -place);
  }
  const int e = std::max(value_exp, place + 1);
  const double scale = std::pow(10.0, e);
  const int decimals = e - place;
  return fmt::format("({:.{}f} ± {:.{}f})e{}", value / scale, decimals, u / scale, decimals, e);
}

namespace {

// Optimal string alignment distance: insertions, deletions, substitutions and a swap of
// neighbours ("mokc" → "mock") each cost one.
std::size_t edit_distance(std::string_view a, std::string_view b) {
  const std::size_t w = b.size() + 1;
  std::vector<std::size_t> d((a.size() + 1) * w);
  for (std::size_t i = 0; i <= a.size(); ++i) d[i * w] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i)
    for (std::size_t j = 1; j <= b.size(); ++j) {
      auto& x = d[i * w + j];
      x = std::min({d[(i - 1) * w + j] + 1, d[i * w + j - 1] + 1,
                    d[(i - 1) * w + j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        x = std::min(x, d[(i - 2) * w + j - 2] + 1);
    }
  return d.back();
}

}  // namespace

std::vector<std::string> near_matches(std::string_view word, const std::vector<std::string>& candidates,
                                      std::size_t max) {
  // A typo: up to a third of the word's letters (at least one, at most three) edited.
  const std::size_t limit = std::clamp<std::size_t>(word.size() / 3, 1, 3);
  std::vector<std::pair<std::size_t, std::string>> scored;
  for (const auto& c : candidates) {
    if (c == word) continue;
    std::size_t d = edit_distance(word, c);
    if (word.size() >= 3 && c.starts_with(word)) d = std::min(d, limit);
    if (d <= limit) scored.emplace_back(d, c);
  }
  std::stable_sort(scored.begin(), scored.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  // Only the nearest: "scan.get" for "scan.gett", not also "scan.fit".
  std::vector<std::string> out;
  for (auto& s : scored) {
    if (out.size() >= max || s.first > scored.front().first) break;
    if (std::find(out.begin(), out.end(), s.second) == out.end()) out.push_back(std::move(s.second));
  }
  return out;
}

std::string did_you_mean(std::string_view word, const std::vector<std::string>& candidates) {
  const auto near = near_matches(word, candidates);
  if (near.empty()) return {};
  std::string out = " (did you mean ";
  for (std::size_t i = 0; i < near.size(); ++i)
    out += fmt::format("{}'{}'", i == 0 ? "" : i + 1 == near.size() ? " or " : ", ", near[i]);
  return out + "?)";
}

}  // namespace gonio::text
