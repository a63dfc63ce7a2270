// CGATS.17 text reader for the spectral tables of colord-data.
//
// The files look like (ANSI CGATS.17 / ISO 28178 layout):
//   SPECT                                  <- file identifier
//   SPECTRAL_START_NM  380.0               <- keyword lines: name, value (may be quoted)
//   BEGIN_DATA_FORMAT  SPEC_380 ... END_DATA_FORMAT
//   BEGIN_DATA  <numbers, any line breaks>  END_DATA
// Data values may wrap across lines; they are split into sets of NUMBER_OF_FIELDS values.
// Every failure names the file and the line, never crashes on malformed input.
#include "color/cgats.hpp"

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"

namespace gonio::twin::cgats {
namespace {

[[noreturn]] void fail(const std::string& path, int line, const std::string& why) {
  throw Error(Errc::parse_error, fmt::format("{}:{}: {}", path, line, why));
}

// Whitespace-separated tokens; a double-quoted string is one token (quotes removed).
std::vector<std::string> tokens(const std::string& line, const std::string& path, int n) {
  std::vector<std::string> out;
  std::size_t i = 0;
  while (i < line.size()) {
    const char c = line[i];
    if (c == ' ' || c == '\t' || c == '\r') {
      ++i;
    } else if (c == '#') {
      break;  // comment to end of line
    } else if (c == '"') {
      const auto end = line.find('"', i + 1);
      if (end == std::string::npos) fail(path, n, "unterminated quoted string");
      out.push_back(line.substr(i + 1, end - i - 1));
      i = end + 1;
    } else {
      std::size_t j = i;
      while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
      out.push_back(line.substr(i, j - i));
      i = j;
    }
  }
  return out;
}

bool to_double(const std::string& s, double& v) {
  const char* first = s.data();
  const char* last = s.data() + s.size();
  if (first != last && *first == '+') ++first;
  const auto [ptr, ec] = std::from_chars(first, last, v);
  return ec == std::errc() && ptr == last && std::isfinite(v);
}

}  // namespace

double Table::number(const std::string& key) const {
  const auto it = keywords.find(key);
  if (it == keywords.end()) fail(path, 1, fmt::format("keyword {} is missing", key));
  double v = 0;
  if (!to_double(it->second.first, v))
    fail(path, it->second.second,
         fmt::format("keyword {} has value '{}', expected a number", key, it->second.first));
  return v;
}

std::vector<double> Table::wavelengths() const {
  const double start = number("SPECTRAL_START_NM");
  const double end = number("SPECTRAL_END_NM");
  const double bands = number("SPECTRAL_BANDS");
  const int line = keywords.at("SPECTRAL_BANDS").second;
  if (!(bands >= 2 && bands <= 100000 && bands == std::floor(bands)))
    fail(path, line, fmt::format("SPECTRAL_BANDS = {:g} is not an integer >= 2", bands));
  if (!(end > start))
    fail(path, keywords.at("SPECTRAL_END_NM").second,
         fmt::format("SPECTRAL_END_NM {:g} is not above SPECTRAL_START_NM {:g}", end, start));
  const auto n = static_cast<std::size_t>(bands);
  if (n != fields.size())
    fail(path, line,
         fmt::format("SPECTRAL_BANDS = {} but the data format has {} fields", n,
                     fields.size()));
  std::vector<double> nm(n);
  for (std::size_t i = 0; i < n; ++i)
    nm[i] = start + (end - start) * static_cast<double>(i) / static_cast<double>(n - 1);
  return nm;
}

Table read(const std::string& path, const std::string& package) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw Error(Errc::not_found,
                fmt::format("CIE table '{}' not found: install the Debian package {} or set "
                            "GONIO_COLORD_DIR to a directory holding its files",
                            path, package));
  std::ifstream in(path);
  if (!in) throw Error(Errc::io_error, fmt::format("cannot open CIE table '{}'", path));

  Table t;
  t.path = path;
  enum class State { header, format, data, done } state = State::header;
  std::vector<double> values;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    const auto tok = tokens(line, path, n);
    if (tok.empty()) continue;
    if (t.type.empty()) {  // the file identifier is the first non-empty line
      t.type = tok.front();
      continue;
    }
    for (std::size_t k = 0; k < tok.size(); ++k) {
      const std::string& w = tok[k];
      switch (state) {
        case State::header:
          if (w == "BEGIN_DATA_FORMAT") {
            state = State::format;
          } else if (w == "BEGIN_DATA") {
            if (t.fields.empty()) fail(path, n, "BEGIN_DATA before BEGIN_DATA_FORMAT");
            state = State::data;
            t.data_line = n;
          } else {
            if (k != 0) fail(path, n, fmt::format("unexpected token '{}'", w));
            if (tok.size() > 2) fail(path, n, fmt::format("keyword {} has several values", w));
            t.keywords[w] = {tok.size() == 2 ? tok[1] : std::string(), n};
            k = tok.size();  // the rest of the line was the value
          }
          break;
        case State::format:
          if (w == "END_DATA_FORMAT") {
            if (t.fields.empty()) fail(path, n, "empty data format");
            state = State::header;
          } else {
            t.fields.push_back(w);
          }
          break;
        case State::data:
          if (w == "END_DATA") {
            state = State::done;
          } else {
            double v = 0;
            if (!to_double(w, v)) fail(path, n, fmt::format("'{}' is not a number", w));
            values.push_back(v);
          }
          break;
        case State::done:
          fail(path, n, fmt::format("unexpected '{}' after END_DATA", w));
      }
    }
  }
  if (in.bad()) throw Error(Errc::io_error, fmt::format("error reading CIE table '{}'", path));
  if (t.type.empty()) fail(path, n, "empty file");
  if (t.fields.empty()) fail(path, n, "no BEGIN_DATA_FORMAT section");
  if (state == State::format) fail(path, n, "END_DATA_FORMAT missing");
  if (state == State::header) fail(path, n, "no BEGIN_DATA section");
  if (state == State::data) fail(path, n, "END_DATA missing");

  const std::size_t nf = t.fields.size();
  if (values.size() % nf != 0)
    fail(path, t.data_line,
         fmt::format("{} data values are not a whole number of sets of {} fields",
                     values.size(), nf));
  if (t.keywords.count("NUMBER_OF_FIELDS") != 0 &&
      t.number("NUMBER_OF_FIELDS") != static_cast<double>(nf))
    fail(path, t.keywords.at("NUMBER_OF_FIELDS").second,
         fmt::format("NUMBER_OF_FIELDS does not match the {} fields of the data format", nf));
  const std::size_t sets = values.size() / nf;
  if (t.keywords.count("NUMBER_OF_SETS") != 0 &&
      t.number("NUMBER_OF_SETS") != static_cast<double>(sets))
    fail(path, t.keywords.at("NUMBER_OF_SETS").second,
         fmt::format("NUMBER_OF_SETS does not match the {} sets in the data", sets));
  for (std::size_t s = 0; s < sets; ++s)
    t.sets.emplace_back(values.begin() + static_cast<std::ptrdiff_t>(s * nf),
                        values.begin() + static_cast<std::ptrdiff_t>((s + 1) * nf));
  return t;
}

}  // namespace gonio::twin::cgats
