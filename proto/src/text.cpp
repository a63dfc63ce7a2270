#include "gonio/proto/text.hpp"

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

}  // namespace gonio::text
