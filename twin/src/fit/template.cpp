// ModelTemplate: a BSDF spec with '?' marks for free parameters.
//
// The marks are cut out of the text and replaced by distinct sentinel numbers; the spec
// parser of the bsdf family then tells which lobe and key (or which wavelength:value pair)
// each sentinel landed in, so the template follows the spec syntax exactly without a second
// parser. The models' parameter tables give the default start and bounds.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <optional>

#include <fmt/format.h>

#include "gonio/twin/detail/bsdf/model.hpp"
#include "gonio/twin/detail/bsdf/spec.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"
#include "gonio/twin/fit.hpp"

namespace gonio::twin {
namespace {

constexpr std::size_t kMaxMarks = 99;

// A number no one writes in a spec, distinct per mark, read back exactly.
std::string sentinel_text(std::size_t k) { return fmt::format("-1.2345e+{}", 200 + k); }
double sentinel_value(std::size_t k) { return std::stod(sentinel_text(k)); }

struct RawMark {
  bool per_channel = false;
  std::optional<double> start;
  std::optional<std::pair<double, double>> bounds;
};

bool number_char(std::string_view s, std::size_t i) {
  const char c = s[i];
  if ((c >= '0' && c <= '9') || c == '.' || c == 'e' || c == 'E') return true;
  if (c == '-') return true;
  // '+' belongs to the number only as an exponent sign ("1e+3"); else it joins lobes.
  return c == '+' && i > 0 && (s[i - 1] == 'e' || s[i - 1] == 'E');
}

// 1. The marks cut out of the text: the literal pieces between them and the spec with each
// mark replaced by its sentinel.
struct CutSpec {
  std::vector<RawMark> marks;
  std::vector<std::string> literals;  // marks.size() + 1 pieces
  std::string substituted;
};

// The mark at spec[i] == '?': ?, ?*, ?START, ?START[LO,HI]; `i` moves past it.
RawMark read_mark(std::string_view spec, std::size_t& i, std::size_t index) {
  const std::size_t at = i++;
  RawMark m;
  if (i < spec.size() && spec[i] == '*') m.per_channel = true, ++i;
  std::size_t j = i;
  while (j < spec.size() && number_char(spec, j)) ++j;
  const auto field = fmt::format("model (mark {} at offset {})", index + 1, at);
  if (j > i) m.start = text::parse_double(field, spec.substr(i, j - i));
  i = j;
  if (i < spec.size() && spec[i] == '[') {
    const auto close = spec.find(']', i);
    if (close == std::string_view::npos)
      throw Error::invalid(field, "'[' without ']': bounds are written [lo,hi]");
    const auto parts = text::split(spec.substr(i + 1, close - i - 1), ',');
    if (parts.size() != 2) throw Error::invalid(field, "bounds are written [lo,hi]");
    const double lo = text::parse_double(field, text::trim(parts[0]));
    const double hi = text::parse_double(field, text::trim(parts[1]));
    if (!(lo < hi)) throw Error::invalid(field, fmt::format("bounds [{:g},{:g}] are empty", lo, hi));
    m.bounds = std::pair{lo, hi};
    i = close + 1;
  }
  // A mark ends where its value would: at ',', '+', white space or the end. Anything else
  // ("alpha=?x") is a typo in the mark, reported here rather than as a bad number later.
  if (i < spec.size() && spec[i] != ',' && spec[i] != '+' && !std::isspace(static_cast<unsigned char>(spec[i])))
    throw Error::invalid(field, fmt::format("unexpected '{}' after the '?' mark: write ?, ?START "
                                            "or ?START[LO,HI]", spec[i]));
  return m;
}

CutSpec cut_marks(std::string_view spec) {
  CutSpec out;
  std::string literal;
  for (std::size_t i = 0; i < spec.size();) {
    if (spec[i] != '?') {
      literal += spec[i++];
      continue;
    }
    if (out.marks.size() == kMaxMarks)
      throw Error::invalid("model", fmt::format("more than {} '?' marks", kMaxMarks));
    out.marks.push_back(read_mark(spec, i, out.marks.size()));
    out.literals.push_back(literal);
    out.substituted += literal + sentinel_text(out.marks.size() - 1);
    literal.clear();
  }
  out.literals.push_back(literal);
  out.substituted += literal;
  if (out.marks.empty())
    throw Error::invalid("model", "no free parameter: mark at least one value with '?' "
                                  "(e.g. conductor:alpha=?,eta=0.2,k=3.9)");
  return out;
}

// 2. Where a sentinel landed: the parameter it is the value of.
struct Found {
  std::string name;             // parameter name without a wavelength
  const bsdf::ParamInfo* info = nullptr;
  std::optional<double> pair_nm;  // the mark is the value of this pair
  bool found = false;
};

std::vector<Found> locate_marks(const std::string& substituted, std::size_t marks) {
  const auto lobes = bsdf::parse_spec_string(substituted);
  std::map<std::string, int> name_count;
  for (const auto& l : lobes) ++name_count[l.name];
  std::map<std::string, int> name_seen;
  std::vector<Found> found(marks);
  for (const auto& l : lobes) {
    const int n = ++name_seen[l.name];
    if (l.name.empty()) continue;  // a tabulated file has no parameters
    const auto* model = bsdf::find_model(l.name);
    const auto lobe_name = name_count[l.name] > 1 ? fmt::format("{}#{}", l.name, n) : l.name;
    for (const auto& arg : l.args) {
      // Not a structured binding: lambdas cannot capture those before clang 16.
      const auto& key = arg.first;
      const auto& value = arg.second;
      const auto locate = [&](double v, std::optional<double> nm) {
        for (std::size_t k = 0; k < marks; ++k) {
          if (v != sentinel_value(k)) continue;
          if (model == nullptr)
            throw Error::invalid("model", fmt::format("unknown lobe '{}'", l.name));
          const auto it = std::find_if(model->params.begin(), model->params.end(),
                                       [&](const bsdf::ParamInfo& p) { return p.key == key; });
          if (it == model->params.end())
            throw Error::invalid(fmt::format("bsdf.{}.{}", l.name, key),
                                 fmt::format("unknown key '{}' for lobe '{}'", key, l.name));
          found[k] = {lobe_name + "." + key, &*it, nm, true};
        }
      };
      if (value.kind == bsdf::RawValue::Kind::number) locate(value.number, std::nullopt);
      if (value.kind == bsdf::RawValue::Kind::pairs)
        for (const auto& [nm, v] : value.pairs) locate(v, nm);
    }
  }
  return found;
}

// 3. A free parameter: its bounds (the model's, or the mark's inside them) and its start.
FreeParameter free_parameter(const RawMark& m, const Found& f, std::size_t index) {
  if (!f.found)
    throw Error::invalid("model", fmt::format("the '?' mark {} is not the value of a "
                                              "parameter (write key=?)", index + 1));
  const auto& p = *f.info;
  const auto field = "bsdf." + f.name;
  if ((m.per_channel || f.pair_nm) && !p.spectral)
    throw Error::invalid(field, "is a scalar parameter: it cannot be free per wavelength");
  if (m.per_channel && f.pair_nm)
    throw Error::invalid(field, "'?*' stands for a whole spectrum, not for one pair's value");
  double lo = p.lo_open ? (p.lo == 0 ? p.hi * 1e-4 : p.lo + 1e-9 * (p.hi - p.lo)) : p.lo;
  double hi = p.hi;
  if (m.bounds) {
    if (m.bounds->first < lo || m.bounds->second > hi)
      throw Error(Errc::out_of_range,
                  fmt::format("{}: bounds [{:g},{:g}] leave the parameter's range [{:g},{:g}]",
                              field, m.bounds->first, m.bounds->second, p.lo, p.hi),
                  field);
    lo = m.bounds->first, hi = m.bounds->second;
  }
  double start = m.start.value_or(p.fallback);
  if (m.start && (start < lo || start > hi))
    throw Error::out_of_range(field, start, lo, hi);
  // A start on a bound would sit where the bounded transform is flat: move it inside, by
  // 10⁻³ of the range in the coordinate the parameter is fitted in.
  const bool log_scale = lo > 0 && hi / lo >= 10;
  if (log_scale)
    start = std::exp(std::clamp(std::log(start), std::log(lo) + 1e-3 * std::log(hi / lo),
                                std::log(hi) - 1e-3 * std::log(hi / lo)));
  else
    start = std::clamp(start, lo + 1e-3 * (hi - lo), hi - 1e-3 * (hi - lo));
  return FreeParameter{f.name, start, lo, hi, log_scale};
}

}  // namespace

ModelTemplate::ModelTemplate(std::string_view spec, const WavelengthGrid& grid)
    : text_(spec), grid_(grid) {
  if (grid.empty()) throw Error::invalid("wavelengths", "a model needs at least one wavelength");
  auto cut = cut_marks(spec);
  literal_ = std::move(cut.literals);
  const auto found = locate_marks(cut.substituted, cut.marks.size());
  for (std::size_t k = 0; k < cut.marks.size(); ++k) {
    const auto& m = cut.marks[k];
    const auto& f = found[k];
    auto fp = free_parameter(m, f, k);
    Mark mark{params_.size(), m.per_channel ? grid_.size() : 1};
    if (m.per_channel) {
      for (std::size_t c = 0; c < grid_.size(); ++c) {
        auto q = fp;
        q.name = fmt::format("{}@{:g}", f.name, grid_[c]);
        params_.push_back(q);
        channel_.push_back(static_cast<int>(c));
      }
    } else {
      if (f.pair_nm) fp.name = fmt::format("{}@{:g}", f.name, *f.pair_nm);
      params_.push_back(fp);
      channel_.push_back(-1);
    }
    marks_.push_back(mark);
  }
  // The template must build at its start values.
  std::vector<double> start;
  for (const auto& p : params_) start.push_back(p.start);
  (void)make_bsdf(this->spec(start), grid_);
}

std::string ModelTemplate::spec(const std::vector<double>& values) const {
  if (values.size() != params_.size())
    throw Error(Errc::internal, fmt::format("{} values for {} free parameters", values.size(),
                                            params_.size()));
  std::string out;
  for (std::size_t k = 0; k < marks_.size(); ++k) {
    out += literal_[k];
    const auto& m = marks_[k];
    if (m.count == 1 && channel_[m.first] < 0) {
      out += text::format_number(values[m.first]);
      continue;
    }
    for (std::size_t c = 0; c < m.count; ++c) {
      if (c > 0) out += ',';
      out += text::format_number(grid_[c]) + ":" + text::format_number(values[m.first + c]);
    }
  }
  out += literal_.back();
  return out;
}

}  // namespace gonio::twin
