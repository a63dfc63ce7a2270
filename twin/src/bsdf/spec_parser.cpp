// Parser of the BSDF spec syntax, string and JSON forms (reference: twin/bsdf_spec.md).
//
// Splitting a sum at '+' only where a lobe name (an identifier followed by ':', '+' or the
// end) or '@' follows keeps exponents such as "1e+3" intact. Inside a lobe, arguments are
// separated by ',' and a piece without '=' continues the previous value, so spectra
// ("albedo=400:0.2,700:0.8") need no quoting.
#include <algorithm>
#include <cctype>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "gonio/twin/detail/bsdf/spec.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/json_util.hpp"
#include "gonio/proto/text.hpp"

namespace gonio::twin::bsdf {
namespace {

bool ident_start(char c) { return std::isalpha(static_cast<unsigned char>(c)) || c == '_'; }
bool ident_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
}
bool space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

// Whether the text after a '+' at `pos` begins a new lobe.
bool lobe_starts_at(std::string_view s, std::size_t pos) {
  while (pos < s.size() && space(s[pos])) ++pos;
  if (pos >= s.size()) return false;
  if (s[pos] == '@') return true;
  if (!ident_start(s[pos])) return false;
  while (pos < s.size() && ident_char(s[pos])) ++pos;
  while (pos < s.size() && space(s[pos])) ++pos;
  return pos == s.size() || s[pos] == ':' || s[pos] == '+';
}

std::string lobe_field(std::string_view name, std::string_view key = {}) {
  return join_field(join_field("bsdf", name), key);
}

LobeSpec parse_lobe(std::string_view text, std::size_t index) {
  text = text::trim(text);
  if (text.empty())
    throw Error::invalid("bsdf", fmt::format("lobe {} is empty (lobes are joined by '+')", index + 1));
  LobeSpec lobe;
  if (text.front() == '@') {
    lobe.file = std::string(text::trim(text.substr(1)));
    if (lobe.file.empty()) throw Error::invalid("bsdf", "'@' needs a file name");
    return lobe;
  }
  const auto colon = text.find(':');
  lobe.name = std::string(text::trim(text.substr(0, colon)));
  if (lobe.name.empty() || !ident_start(lobe.name.front()) ||
      !std::all_of(lobe.name.begin(), lobe.name.end(), ident_char))
    throw Error::invalid("bsdf", fmt::format("'{}' is not a lobe name", lobe.name));
  if (colon == std::string_view::npos) return lobe;
  const auto rest = text::trim(text.substr(colon + 1));
  if (rest.empty()) return lobe;

  // Group the pieces: a piece with '=' opens an argument, one without continues it.
  std::vector<std::pair<std::string, std::string>> raw;
  for (const auto piece : text::split(rest, ',')) {
    const auto eq = piece.find('=');
    if (eq == std::string_view::npos) {
      if (raw.empty())
        throw Error::invalid(lobe_field(lobe.name),
                             fmt::format("'{}' is not key=value", text::trim(piece)));
      raw.back().second += ",";
      raw.back().second += piece;
      continue;
    }
    const auto key = text::trim(piece.substr(0, eq));
    if (key.empty())
      throw Error::invalid(lobe_field(lobe.name), fmt::format("'{}' has no key", text::trim(piece)));
    raw.emplace_back(std::string(key), std::string(piece.substr(eq + 1)));
  }
  for (auto& [key, value] : raw) {
    const auto field = lobe_field(lobe.name, key);
    lobe.args.emplace_back(key, parse_value_text(value, field));
  }
  return lobe;
}

RawValue json_value(const nlohmann::json& j, const std::string& field) {
  if (j.is_number()) {
    const double v = j.get<double>();
    if (!std::isfinite(v)) throw Error::invalid(field, "is not a finite number");
    return RawValue::of(v);
  }
  if (j.is_string()) return parse_value_text(j.get<std::string>(), field);
  RawValue v;
  v.kind = RawValue::Kind::pairs;
  if (j.is_object()) {
    // {"400": 0.2, "700": 0.8}: keys are wavelengths; JSON objects have no order.
    for (const auto& [nm, value] : j.items())
      v.pairs.emplace_back(text::parse_double(field, nm),
                           json_util::get_as<double>(value, fmt::format("{}[\"{}\"]", field, nm)));
    std::sort(v.pairs.begin(), v.pairs.end());
  } else if (j.is_array()) {
    // [[400, 0.2], [700, 0.8]]
    for (std::size_t i = 0; i < j.size(); ++i) {
      const auto f = fmt::format("{}[{}]", field, i);
      if (!j[i].is_array() || j[i].size() != 2)
        throw Error::invalid(f, "expected a [wavelength, value] pair");
      v.pairs.emplace_back(json_util::get_as<double>(j[i][0], f + "[0]"),
                           json_util::get_as<double>(j[i][1], f + "[1]"));
    }
  } else {
    throw Error::invalid(field, "expected a number, a spectrum ({\"400\": 0.2, ...} or "
                                "[[400, 0.2], ...]) or a string, got " + json_util::type_name(j));
  }
  check_pairs(v.pairs, field);
  return v;
}

LobeSpec json_lobe(const nlohmann::json& j, const std::string& context) {
  if (!j.is_object())
    throw Error::invalid(context, "expected a spec string or an object with \"type\", got " +
                                      json_util::type_name(j));
  const auto it = j.find("type");
  if (it == j.end()) throw Error::invalid(join_field(context, "type"), "is required");
  LobeSpec lobe;
  lobe.name = json_util::get_as<std::string>(*it, join_field(context, "type"));
  if (lobe.name == "file") {
    json_util::ObjectReader r(j, context);
    (void)r.raw("type");
    lobe.file = r.required<std::string>("path");
    if (lobe.file.empty()) throw Error::invalid(r.path("path"), "is empty");
    r.finish();
    lobe.name.clear();
    return lobe;
  }
  for (const auto& [key, value] : j.items()) {
    if (key == "type") continue;
    lobe.args.emplace_back(key, json_value(value, lobe_field(lobe.name, key)));
  }
  return lobe;
}

}  // namespace

std::vector<LobeSpec> parse_spec_string(std::string_view spec) {
  if (spec.size() > kMaxSpecBytes)
    throw Error::invalid("bsdf", fmt::format("spec is longer than {} bytes", kMaxSpecBytes));
  spec = text::trim(spec);
  if (spec.empty()) throw Error::invalid("bsdf", "empty spec");
  std::vector<LobeSpec> lobes;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= spec.size(); ++i) {
    if (i < spec.size() && !(spec[i] == '+' && lobe_starts_at(spec, i + 1))) continue;
    if (lobes.size() == kMaxLobes)
      throw Error::invalid("bsdf", fmt::format("more than {} lobes", kMaxLobes));
    lobes.push_back(parse_lobe(spec.substr(start, i - start), lobes.size()));
    start = i + 1;
  }
  return lobes;
}

std::vector<LobeSpec> parse_spec_json(const nlohmann::json& spec) {
  if (spec.is_string()) return parse_spec_string(spec.get_ref<const std::string&>());
  if (spec.is_object()) return {json_lobe(spec, "bsdf")};
  if (!spec.is_array())
    throw Error::invalid("bsdf", "expected a spec string, an object or an array of lobes, got " +
                                     json_util::type_name(spec));
  if (spec.empty()) throw Error::invalid("bsdf", "an empty array has no lobes");
  std::vector<LobeSpec> lobes;
  for (std::size_t i = 0; i < spec.size(); ++i) {
    const auto context = fmt::format("bsdf[{}]", i);
    if (spec[i].is_string()) {
      auto more = parse_spec_string(spec[i].get_ref<const std::string&>());
      for (auto& l : more) lobes.push_back(std::move(l));
    } else {
      lobes.push_back(json_lobe(spec[i], context));
    }
    if (lobes.size() > kMaxLobes)
      throw Error::invalid("bsdf", fmt::format("more than {} lobes", kMaxLobes));
  }
  return lobes;
}

}  // namespace gonio::twin::bsdf
