// Small text helpers shared by every parser of user input: numbers, lists and ranges.
//
// The list syntax is used for geometry grids and wavelength grids alike:
//   item  := number | start:stop:step
//   list  := item (',' item)*
// Ranges include `stop` when it lies on the step grid (within 1e-9 of a step).
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace gonio::text {

std::string_view trim(std::string_view s) noexcept;
// Splits on `sep`; empty pieces are kept so that callers can report them.
std::vector<std::string_view> split(std::string_view s, char sep);

// Parses a whole string as a finite double; throws Error(invalid_argument) naming `field`.
double parse_double(std::string_view field, std::string_view s);
long long parse_int(std::string_view field, std::string_view s);

// Expands a value list (see above). At most `max_count` values; throws naming `field`.
std::vector<double> parse_value_list(std::string_view field, std::string_view s,
                                     std::size_t max_count = 100000);

// Inverse of parse_value_list: compresses arithmetic runs of 3+ values into ranges.
std::string format_value_list(const std::vector<double>& values);

// Shortest decimal text that reads back as the same double ("45", "0.05", "-80").
std::string format_number(double v);

// A value with its standard uncertainty, rounded as GUM §7.2.6 asks: u to two significant
// digits, the value to the same decimal place ("0.3454 ± 0.0137" → "0.345 ± 0.014"). Very
// small or large decimal places use a common exponent: "(2.000000 ± 0.000093)e-2". A u
// that is not positive and finite leaves the value with 6 significant digits, alone.
std::string format_measured(double value, double u);

// The candidates closest to `word` by edit distance (a typo or two, or a prefix), best
// first (only those as near as the nearest), at most `max` of them: for "did you mean ..."
// in errors about unknown names.
std::vector<std::string> near_matches(std::string_view word, const std::vector<std::string>& candidates,
                                      std::size_t max = 3);
// " (did you mean 'mock'?)", " (did you mean 'a' or 'b'?)", or "" when nothing is near.
std::string did_you_mean(std::string_view word, const std::vector<std::string>& candidates);

}  // namespace gonio::text
