// Parsing of SCPI reply lines: numbers (IEEE 488.2 §8.7.2–8.7.4 NR1/NR2/NR3 with the
// SCPI-1999 Vol. 1 §7.2.1.5 infinity / NaN encodings), lists, booleans, error queue entries
// (SCPI-1999 Vol. 2 §21.8) and *IDN? (IEEE 488.2 §10.14). Strict: anything else is a
// protocol error that quotes the offending reply (shortened).
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "gonio/drivers/scpi/scpi.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::drivers::scpi {
namespace {

std::string quoted(std::string_view s) {
  std::string out;
  for (const char c : s.substr(0, 60)) {
    const auto u = static_cast<unsigned char>(c);
    out += (u >= 0x20 && u < 0x7F) ? std::string(1, c) : fmt::format("\\x{:02x}", u);
  }
  if (s.size() > 60) out += fmt::format("... ({} bytes)", s.size());
  return "'" + out + "'";
}

[[noreturn]] void bad(std::string_view what, std::string_view reply, std::string_view why) {
  throw Error(Errc::protocol_error,
              fmt::format("device reply {} is not a valid {}: {}", quoted(reply), what, why));
}

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

}  // namespace

std::string_view trim(std::string_view s) noexcept {
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  return s;
}

double parse_number(std::string_view reply, std::string_view what) {
  const auto s = trim(reply);
  if (s.empty()) bad(what, reply, "empty");
  // from_chars accepts "inf"/"nan" and hex floats only on request: restrict the alphabet
  // to decimal numbers first.
  for (const char c : s)
    if (!(std::isdigit(static_cast<unsigned char>(c)) || c == '+' || c == '-' || c == '.' ||
          c == 'e' || c == 'E'))
      bad(what, reply, "unexpected character");
  std::string_view body = s;
  if (body.front() == '+') body.remove_prefix(1);  // from_chars rejects a leading '+'
  double v = 0;
  const auto [p, ec] = std::from_chars(body.data(), body.data() + body.size(), v);
  if (ec == std::errc::result_out_of_range) bad(what, reply, "out of range");
  if (ec != std::errc() || p != body.data() + body.size()) bad(what, reply, "not a number");
  if (std::fabs(v) == 9.91e37) return std::numeric_limits<double>::quiet_NaN();
  if (std::fabs(v) == 9.9e37) return std::copysign(std::numeric_limits<double>::infinity(), v);
  return v;
}

std::vector<double> parse_numbers(std::string_view reply, std::string_view what,
                                  std::size_t max_count) {
  std::vector<double> out;
  auto s = trim(reply);
  if (s.empty()) bad(what, reply, "empty");
  for (;;) {
    const auto comma = s.find(',');
    if (out.size() == max_count)
      bad(what, reply, fmt::format("more than {} values", max_count));
    out.push_back(parse_number(s.substr(0, comma), what));
    if (comma == std::string_view::npos) break;
    s.remove_prefix(comma + 1);
  }
  return out;
}

bool parse_bool(std::string_view reply, std::string_view what) {
  const auto s = trim(reply);
  if (s == "1" || s == "ON" || s == "on") return true;
  if (s == "0" || s == "OFF" || s == "off") return false;
  bad(what, reply, "expected 0, 1, ON or OFF");
}

ErrorEntry parse_error_entry(std::string_view reply) {
  const auto s = trim(reply);
  const auto comma = s.find(',');
  if (comma == std::string_view::npos) bad("error queue entry", reply, "expected <code>,\"<text>\"");
  ErrorEntry e;
  auto code = trim(s.substr(0, comma));
  if (code.size() > 1 && code.front() == '+') code.remove_prefix(1);  // NR1 may carry a sign
  const auto [p, ec] = std::from_chars(code.data(), code.data() + code.size(), e.code);
  if (code.empty() || ec != std::errc() || p != code.data() + code.size())
    bad("error queue entry", reply, "the code is not an integer");
  auto text = trim(s.substr(comma + 1));
  if (text.size() < 2 || text.front() != '"' || text.back() != '"')
    bad("error queue entry", reply, "the text is not a quoted string");
  text = text.substr(1, text.size() - 2);
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '"') {  // IEEE 488.2 §8.7.8: an embedded quote is doubled
      if (i + 1 >= text.size() || text[i + 1] != '"')
        bad("error queue entry", reply, "unescaped quote in the text");
      ++i;
    }
    // The text goes into logs, alerts and JSON replies: bytes that are not printable ASCII
    // (a control byte, another encoding) are written as \xNN.
    const auto u = static_cast<unsigned char>(text[i]);
    e.message += (u >= 0x20 && u < 0x7F) ? std::string(1, text[i]) : fmt::format("\\x{:02x}", u);
  }
  return e;
}

Identity parse_identity(std::string_view reply) {
  const auto s = trim(reply);
  std::vector<std::string> f;
  std::size_t start = 0;
  for (;;) {
    const auto comma = s.find(',', start);
    f.emplace_back(trim(s.substr(start, comma - start)));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  if (f.size() != 4) bad("*IDN? reply", reply, fmt::format("{} fields, expected 4", f.size()));
  for (const auto& field : f)
    for (const char c : field)
      if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7F)
        bad("*IDN? reply", reply, "non-printable character");
  if (f[0].empty() || f[1].empty()) bad("*IDN? reply", reply, "empty manufacturer or model");
  return Identity{f[0], f[1], f[2], f[3]};
}

}  // namespace gonio::drivers::scpi
