// Surface Scattering Distribution Data (.ssdd): reader and writer.
//
// Format: libbsdf doc/SsddFileFormatSpecification.md, version 0.3 (Kimura, 2026; 0.2 of 2023
// reads the same): a header
// starting with "VERSION <major>.<minor>", then up to four data blocks (brdf, btdf,
// specular_reflectance, specular_transmittance), each ASCII meta-data in a fixed order —
// DATA_TYPE, COLOR_MODEL, WAVELENGTH_LIST, PARAM_TYPE, REDUCTION_TYPE, PARAM0…4_LIST,
// optional entries, DATA ascii|binary — followed by one colour per direction pair
// (index = i0 + n0·(i1 + n1·(i2 + n2·i3))), as text lines or as IEEE 754 float32
// little-endian. The parametrizations and reductions are those of BsdfTable, which was
// modelled on this format, so reading and writing are exact up to the float32 of binary data.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"
#include "gonio/twin/bsdf_io.hpp"
#include "tabulated/common.hpp"

namespace gonio::twin {
namespace {

enum class DataType { brdf, btdf, specular_reflectance, specular_transmittance };
enum class ColorModel { monochrome, rgb, xyz, spectrum };

constexpr std::string_view kTypeNames[4] = {"brdf", "btdf", "specular_reflectance",
                                            "specular_transmittance"};

struct Meta {
  DataType type{};
  std::size_t line = 0;  // of DATA_TYPE
  std::optional<ColorModel> color;
  std::vector<double> wavelengths;
  std::optional<TableParam> param;
  TableReduction reduction;
  std::optional<std::vector<double>> p[5];
  std::string name;
  int order = 0;
  std::set<std::string, std::less<>> seen;
};

int order_of(std::string_view key) {
  if (key == "COLOR_MODEL") return 1;
  if (key == "WAVELENGTH_LIST") return 2;
  if (key == "PARAM_TYPE") return 3;
  if (key == "REDUCTION_TYPE") return 4;
  if (key == "PARAM0_LIST") return 5;
  if (key == "PARAM1_LIST") return 6;
  if (key == "PARAM2_LIST") return 7;
  if (key == "PARAM3_LIST") return 8;
  if (key == "PARAM4_LIST") return 9;
  if (key == "NAME" || key == "SOURCE_TYPE" || key == "DEVICE" || key == "CREATION_DATE" ||
      key == "MEASUREMENT_DATE")
    return 10;
  if (key == "DATA") return 11;
  return 0;
}

std::string_view rest_of_line(std::string_view line, std::string_view key) {
  line = tab::LineReader::trimmed(line);
  line.remove_prefix(std::min(line.size(), key.size()));
  return tab::LineReader::trimmed(line);
}

// Free text on one line: control characters become spaces, ends trimmed (the reader applies
// the same rule, so names round-trip).
std::string one_line(std::string_view in) {
  std::string s(tab::LineReader::trimmed(in));
  for (auto& c : s)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  return std::string(tab::LineReader::trimmed(s));
}

std::vector<double> read_numbers(const tab::LineReader& r, const std::vector<std::string_view>& t,
                                 std::string_view key) {
  if (t.size() < 2) r.fail(fmt::format("{} needs at least one value", key), key);
  if (t.size() - 1 > BsdfTable::kMaxNodes)
    r.fail(fmt::format("{} has more than {} values", key, BsdfTable::kMaxNodes), key);
  std::vector<double> v;
  v.reserve(t.size() - 1);
  for (std::size_t i = 1; i < t.size(); ++i) {
    const double x = r.number(t[i], key);
    if (!v.empty() && !(x > v.back()))
      r.fail(fmt::format("{} value {:g} does not increase on {:g}", key, x, v.back()), key);
    v.push_back(x);
  }
  return v;
}

void check_range(const tab::LineReader& r, const std::vector<double>& v, std::string_view key,
                 double lo, double hi) {
  for (const double x : v)
    if (x < lo || x > hi)
      r.fail(fmt::format("{} value {:g} is outside [{:g}, {:g}] deg", key, x, lo, hi), key);
}

// Range of PARAMk for the block's parametrization (specular_* blocks use the spherical one).
void param_range(const Meta& m, int k, double& lo, double& hi) {
  lo = 0;
  hi = 90;
  const TableParam p = m.param.value_or(TableParam::spherical);
  if (k == 1) hi = 360;
  if (k == 2 && p == TableParam::specular) hi = 180;
  if (k == 3) {
    hi = p == TableParam::half_difference && m.reduction.reciprocal ? 180 : 360;
    if (m.reduction.bilateral) hi /= 2;
  }
  if (k == 4) lo = -90;
}

void read_meta_entry(tab::LineReader& r, Meta& m, std::string_view line,
                     const std::vector<std::string_view>& t) {
  const std::string_view key = t[0];
  const int ord = order_of(key);
  if (ord == 0)
    r.fail(fmt::format("unknown SSDD entry '{}'", key), key);
  if (m.seen.count(key)) r.fail(fmt::format("{} given twice in one block", key), key);
  if (ord < m.order)
    r.fail(fmt::format("{} out of order (the specification fixes the order of entries)", key), key);
  m.seen.emplace(key);
  m.order = ord;
  const bool bsdf = m.type == DataType::brdf || m.type == DataType::btdf;
  if (key == "COLOR_MODEL") {
    if (t.size() != 2) r.fail("COLOR_MODEL takes one value", key);
    if (t[1] == "monochrome") m.color = ColorModel::monochrome;
    else if (t[1] == "rgb") m.color = ColorModel::rgb;
    else if (t[1] == "xyz") m.color = ColorModel::xyz;
    else if (t[1] == "spectrum") m.color = ColorModel::spectrum;
    else r.fail(fmt::format("COLOR_MODEL '{}' is not monochrome, rgb, xyz or spectrum", t[1]), key);
  } else if (key == "WAVELENGTH_LIST") {
    m.wavelengths = read_numbers(r, t, key);
    for (const double x : m.wavelengths)
      if (!(x > 0) || x > 1e5) r.fail(fmt::format("wavelength {:g} nm is out of range", x), key);
  } else if (key == "PARAM_TYPE") {
    if (!bsdf) r.fail(fmt::format("PARAM_TYPE is not used by {} blocks", kTypeNames[static_cast<int>(m.type)]), key);
    if (t.size() != 2) r.fail("PARAM_TYPE takes one value", key);
    if (t[1] == "spherical_coordinate_system") m.param = TableParam::spherical;
    else if (t[1] == "specular_coordinate_system") m.param = TableParam::specular;
    else if (t[1] == "half_difference_coordinate_system") m.param = TableParam::half_difference;
    else r.unsupported(fmt::format("PARAM_TYPE '{}' is not supported", t[1]), key);
    if (m.type == DataType::btdf && m.param == TableParam::half_difference)
      r.unsupported("a btdf in half_difference_coordinate_system is not supported", key);
  } else if (key == "REDUCTION_TYPE") {
    if (!bsdf) r.fail("REDUCTION_TYPE is only for brdf and btdf blocks", key);
    if (t.size() < 2 || t.size() > 3) r.fail("REDUCTION_TYPE takes one or two values", key);
    for (std::size_t i = 1; i < t.size(); ++i) {
      if (t[i] == "bilateral_symmetry") m.reduction.bilateral = true;
      else if (t[i] == "reciprocity") m.reduction.reciprocal = true;
      else r.fail(fmt::format("REDUCTION_TYPE '{}' is not bilateral_symmetry or reciprocity", t[i]), key);
    }
    if (m.reduction.reciprocal && m.param != TableParam::half_difference)
      r.fail("reciprocity reduction is only valid for half_difference_coordinate_system", key);
  } else if (key.starts_with("PARAM") && key.ends_with("_LIST")) {
    const int k = key[5] - '0';
    if (!bsdf && k >= 2)
      r.fail(fmt::format("{} is not used by {} blocks", key, kTypeNames[static_cast<int>(m.type)]), key);
    if (k == 4 && m.param != TableParam::specular)
      r.fail("PARAM4_LIST is only for specular_coordinate_system", key);
    std::vector<double> v;
    if (k == 4) {  // offsets: one per incidence angle, in any order
      if (t.size() < 2 || t.size() - 1 > BsdfTable::kMaxNodes)
        r.fail(fmt::format("{} needs 1 to {} values", key, BsdfTable::kMaxNodes), key);
      for (std::size_t i = 1; i < t.size(); ++i) v.push_back(r.number(t[i], key));
    } else {
      v = read_numbers(r, t, key);
    }
    double lo = 0, hi = 0;
    param_range(m, k, lo, hi);
    check_range(r, v, key, lo, hi);
    m.p[k] = std::move(v);
  } else if (key == "NAME") {
    m.name = one_line(rest_of_line(line, key));
  } else if (key == "SOURCE_TYPE") {
    if (t.size() != 2 || (t[1] != "measured" && t[1] != "generated" && t[1] != "edited"))
      r.fail("SOURCE_TYPE is measured, generated or edited", key);
  }
  // DEVICE, CREATION_DATE, MEASUREMENT_DATE: free text, kept only in the file.
}

std::size_t channels_of(const Meta& m) {
  switch (*m.color) {
    case ColorModel::monochrome: return 1;
    case ColorModel::rgb:
    case ColorModel::xyz: return 3;
    case ColorModel::spectrum: return m.wavelengths.size();
  }
  return 1;
}

// Reads the block's colours in file order.
std::vector<double> read_data(tab::LineReader& r, const Meta& m, bool binary, std::size_t count,
                              std::size_t ch) {
  std::vector<double> v;
  v.reserve(std::min<std::size_t>(count * ch, 1 << 16));
  const bool specular = m.type == DataType::specular_reflectance ||
                        m.type == DataType::specular_transmittance;
  if (binary) {
    auto& in = r.stream();
    const std::size_t data_line = r.line();
    char buf[4 * 1024];
    std::size_t done = 0;
    const std::size_t total = count * ch;
    while (done < total) {
      const std::size_t n = std::min<std::size_t>(total - done, sizeof buf / 4);
      in.read(buf, static_cast<std::streamsize>(n * 4));
      if (static_cast<std::size_t>(in.gcount()) != n * 4)
        throw Error(Errc::parse_error,
                    fmt::format("{}:{}: binary data end after {} of {} values", r.source(),
                                data_line, done + static_cast<std::size_t>(in.gcount()) / 4, total),
                    "DATA");
      for (std::size_t i = 0; i < n; ++i) {
        const auto* b = reinterpret_cast<const unsigned char*>(buf + 4 * i);
        const std::uint32_t bits = std::uint32_t{b[0]} | std::uint32_t{b[1]} << 8 |
                                   std::uint32_t{b[2]} << 16 | std::uint32_t{b[3]} << 24;
        const double x = std::bit_cast<float>(bits);
        if (!std::isfinite(x) || x < 0 || x > (specular ? 1.0 : BsdfTable::kMaxF))
          throw Error(Errc::parse_error,
                      fmt::format("{}:{}: binary value {} of the block is {} (must be finite, "
                                  ">= 0 and <= {:g})", r.source(), data_line, done + i, x,
                                  specular ? 1.0 : BsdfTable::kMaxF),
                      "DATA");
        v.push_back(x);
      }
      done += n;
    }
    return v;
  }
  std::string line;
  for (std::size_t k = 0; k < count; ++k) {
    if (!r.next_content(line))
      r.fail(fmt::format("end of file after {} of {} data lines", k, count), "DATA");
    const auto t = tab::tokens(line);
    if (t.size() != ch)
      r.fail(fmt::format("data line has {} values, the colour model needs {} (is the grid "
                         "larger than the data?)", t.size(), ch), "DATA");
    for (const auto tok : t) {
      const double x = r.number(tok, "value");
      if (x < 0) r.fail(fmt::format("value {} is negative", tok), "value");
      if (x > BsdfTable::kMaxF) r.fail(fmt::format("value {} is beyond 1e12 sr^-1", tok), "value");
      if (specular && x > 1) r.fail(fmt::format("specular value {} exceeds 1", tok), "value");
      v.push_back(x);
    }
  }
  return v;
}

void finish_block(tab::LineReader& r, Meta& m, std::string_view mode, TabulatedParts& parts) {
  const bool bsdf = m.type == DataType::brdf || m.type == DataType::btdf;
  if (!m.color) r.fail("the block lacks COLOR_MODEL", "COLOR_MODEL");
  if (*m.color == ColorModel::spectrum && m.wavelengths.empty())
    r.fail("COLOR_MODEL spectrum needs WAVELENGTH_LIST", "WAVELENGTH_LIST");
  if (*m.color != ColorModel::spectrum && !m.wavelengths.empty())
    r.fail("WAVELENGTH_LIST is only for COLOR_MODEL spectrum", "WAVELENGTH_LIST");
  if (!m.p[0]) r.fail("the block lacks PARAM0_LIST", "PARAM0_LIST");
  if (bsdf) {
    if (!m.param) r.fail("brdf and btdf blocks need PARAM_TYPE", "PARAM_TYPE");
    if (!m.p[2]) r.fail("the block lacks PARAM2_LIST", "PARAM2_LIST");
    if (!m.p[3]) r.fail("the block lacks PARAM3_LIST", "PARAM3_LIST");
    if (m.p[4]) {
      if (m.p[4]->size() != m.p[0]->size())
        r.fail(fmt::format("PARAM4_LIST has {} offsets for {} incoming polar angles",
                           m.p[4]->size(), m.p[0]->size()), "PARAM4_LIST");
      for (const double x : *m.p[4])
        if (x != 0)
          r.unsupported("specular offsets (PARAM4_LIST) other than 0 are not supported",
                        "PARAM4_LIST");
    }
  }
  if (mode != "ascii" && mode != "binary")
    r.fail(fmt::format("DATA '{}' is not ascii or binary", mode), "DATA");
  const std::size_t ch = channels_of(m);
  const std::size_t n0 = m.p[0]->size(), n1 = m.p[1] ? m.p[1]->size() : 1;
  const std::size_t n2 = bsdf ? m.p[2]->size() : 1, n3 = bsdf ? m.p[3]->size() : 1;
  // Guard the product before multiplying it out (each factor is <= kMaxNodes).
  if (n0 * n1 > BsdfTable::kMaxValues || n2 * n3 > BsdfTable::kMaxValues ||
      (n0 * n1) * (n2 * n3) > BsdfTable::kMaxValues / ch)
    r.fail(fmt::format("the block declares more than {} values", BsdfTable::kMaxValues), "DATA");
  const std::size_t count = n0 * n1 * n2 * n3;
  std::vector<double> raw = read_data(r, m, mode == "binary", count, ch);

  // Colour model → table wavelengths.
  std::vector<double> nm, values;
  switch (*m.color) {
    case ColorModel::monochrome: values = std::move(raw); break;
    case ColorModel::spectrum:
      values = std::move(raw);
      nm = m.wavelengths;
      break;
    case ColorModel::rgb:  // R, G, B → spectrum at kRgbWavelengthsNm (B, G, R)
      nm.assign(kRgbWavelengthsNm.begin(), kRgbWavelengthsNm.end());
      values.resize(raw.size());
      for (std::size_t k = 0; k < count; ++k)
        for (std::size_t c = 0; c < 3; ++c) values[k * 3 + c] = raw[k * 3 + 2 - c];
      break;
    case ColorModel::xyz:  // Y, the luminance factor, as grey
      values.resize(count);
      for (std::size_t k = 0; k < count; ++k) values[k] = raw[k * 3 + 1];
      break;
  }
  try {
    if (bsdf) {
      BsdfTable t(*m.param, {*m.p[0], m.p[1] ? *m.p[1] : std::vector<double>{}, *m.p[2], *m.p[3]},
                  std::move(nm), std::move(values), m.reduction);
      (m.type == DataType::brdf ? parts.brdf : parts.btdf) = std::move(t);
    } else {
      SpecularTable t(*m.p[0], m.p[1] ? *m.p[1] : std::vector<double>{}, std::move(nm),
                      std::move(values));
      (m.type == DataType::specular_reflectance ? parts.specular_reflectance
                                                : parts.specular_transmittance) = std::move(t);
    }
  } catch (const Error& e) {
    throw Error(Errc::parse_error,
                fmt::format("{}:{}: {} block: {}", r.source(), m.line,
                            kTypeNames[static_cast<int>(m.type)], e.what()),
                e.field());
  }
  if (parts.name.empty()) parts.name = m.name;
}

std::string list_text(const std::vector<double>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? " " : "") + text::format_number(v[i]);
  return s;
}


void write_values(std::ostream& os, const std::vector<double>& values, std::size_t ch,
                  bool binary, const std::vector<double>* p2, const std::vector<double>* p3,
                  std::size_t n0n1) {
  if (binary) {
    char bytes[4096];
    std::size_t n = 0;
    for (const double x : values) {
      const auto bits = std::bit_cast<std::uint32_t>(static_cast<float>(x));
      for (int k = 0; k < 4; ++k) bytes[n++] = static_cast<char>((bits >> (8 * k)) & 0xff);
      if (n == sizeof bytes) {
        os.write(bytes, static_cast<std::streamsize>(n));
        n = 0;
      }
    }
    bytes[n++] = '\n';
    os.write(bytes, static_cast<std::streamsize>(n));
    return;
  }
  // Formatted in a buffer flushed every ~64 kB: no copy of the whole file in memory.
  fmt::memory_buffer buf;
  const auto out = std::back_inserter(buf);
  const std::size_t rows = values.size() / ch;
  for (std::size_t k = 0; k < rows; ++k) {
    if (buf.size() > (1 << 16)) {
      os.write(buf.data(), static_cast<std::streamsize>(buf.size()));
      buf.clear();
    }
    if (p2 && p3 && k % n0n1 == 0) {
      const std::size_t i23 = k / n0n1, i2 = i23 % p2->size(), i3 = i23 / p2->size();
      if (i2 == 0) fmt::format_to(out, "# PARAM3: {}\n", text::format_number((*p3)[i3]));
      fmt::format_to(out, "# PARAM2: {}\n", text::format_number((*p2)[i2]));
    }
    for (std::size_t c = 0; c < ch; ++c) {
      if (c) buf.push_back(' ');
      fmt::format_to(out, "{}", values[k * ch + c]);
    }
    buf.push_back('\n');
  }
  os.write(buf.data(), static_cast<std::streamsize>(buf.size()));
}

void write_color(std::ostream& os, const std::vector<double>& nm) {
  if (nm.empty()) {
    os << "COLOR_MODEL monochrome\n";
  } else {
    os << "COLOR_MODEL spectrum\nWAVELENGTH_LIST " << list_text(nm) << '\n';
  }
}

}  // namespace

TabulatedParts read_ssdd(std::istream& in, std::string_view source) {
  tab::LineReader r(in, source);
  std::string line;
  if (!r.next_content(line)) r.fail("empty file: an SSDD file starts with VERSION", "VERSION");
  {
    const auto t = tab::tokens(line);
    if (t[0] != "VERSION") r.fail(fmt::format("an SSDD file starts with VERSION, not '{}'", t[0]), "VERSION");
    if (t.size() != 2) r.fail("VERSION takes one value, <major>.<minor>", "VERSION");
    const std::string_view v = t[1];
    const auto dot = v.find('.');
    const auto digits = [](std::string_view d) {
      return !d.empty() && std::all_of(d.begin(), d.end(), [](char c) { return c >= '0' && c <= '9'; });
    };
    if (dot == std::string_view::npos || !digits(v.substr(0, dot)) || !digits(v.substr(dot + 1)))
      r.fail(fmt::format("VERSION '{}' is not <major>.<minor>", v), "VERSION");
    if (v.substr(0, dot) != "0")
      r.unsupported(fmt::format("SSDD version {} is not supported (0.x is)", v), "VERSION");
  }

  TabulatedParts parts;
  std::optional<Meta> meta;
  bool seen_type[4] = {false, false, false, false};
  bool any_block = false;
  while (r.next_content(line)) {
    const auto t = tab::tokens(line);
    const std::string_view key = t[0];
    if (key == "DATA_TYPE") {
      if (meta) r.fail("a new DATA_TYPE before the previous block's DATA", key);
      if (t.size() != 2) r.fail("DATA_TYPE takes one value", key);
      int type = -1;
      for (int k = 0; k < 4; ++k)
        if (t[1] == kTypeNames[k]) type = k;
      if (type < 0)
        r.fail(fmt::format("DATA_TYPE '{}' is not brdf, btdf, specular_reflectance or "
                           "specular_transmittance", t[1]), key);
      if (seen_type[type]) r.fail(fmt::format("a second {} block", t[1]), key);
      seen_type[type] = true;
      any_block = true;
      meta.emplace();
      meta->type = static_cast<DataType>(type);
      meta->line = r.line();
    } else if (!meta) {
      if (!any_block && (key == "SOFTWARE" || key == "API" || key == "DATE")) continue;
      if (key == "VERSION") r.fail("VERSION given twice", key);
      r.fail(fmt::format("'{}' outside a data block (expected SOFTWARE, API, DATE or DATA_TYPE)",
                         key), key);
    } else if (key == "DATA") {
      read_meta_entry(r, *meta, line, t);
      if (t.size() != 2) r.fail("DATA takes one value, ascii or binary", key);
      finish_block(r, *meta, t[1], parts);
      meta.reset();
    } else {
      read_meta_entry(r, *meta, line, t);
    }
  }
  if (meta) r.fail(fmt::format("end of file inside the {} block (no DATA entry)",
                               kTypeNames[static_cast<int>(meta->type)]), "DATA");
  if (parts.empty()) r.fail("the file holds no data block", "DATA_TYPE");
  return parts;
}

TabulatedParts read_ssdd(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(Errc::not_found, fmt::format("cannot open '{}'", path), "path");
  return read_ssdd(in, path);
}

std::vector<std::string> write_ssdd(std::ostream& out, const TabulatedParts& parts,
                                    const SsddWriteOptions& o) {
  if (parts.empty()) throw Error::invalid("parts", "hold no table");
  const bool binary = o.data == SsddData::binary;
  // Energy check of the BRDF and BTDF blocks at their own incidence nodes (spherical and
  // specular tables; the θh of a half-difference table is no incidence angle, so those are
  // checked on a 5° list).
  std::vector<std::string> warnings;
  const auto check = [&](const BsdfTable& t, bool transmission) {
    std::vector<double> ti = t.axis(0);
    if (t.param() == TableParam::half_difference) {
      ti.clear();
      for (int k = 0; k <= 17; ++k) ti.push_back(5.0 * k);
    }
    for (auto& w : energy_warnings(t, transmission, ti))
      warnings.push_back(std::string(transmission ? "btdf: " : "brdf: ") + w);
  };
  if (parts.brdf) check(*parts.brdf, false);
  if (parts.btdf) check(*parts.btdf, true);

  std::ostream& os = out;
  std::string comment = o.comment;
  if (!o.name_entry && !parts.name.empty())
    comment += (comment.empty() ? "" : "\n") + one_line(parts.name);
  for (const auto& w : warnings) comment += (comment.empty() ? "" : "\n") + ("warning: " + w);
  if (!comment.empty()) {
    std::istringstream cs(comment);
    for (std::string l; std::getline(cs, l);) os << "# " << l << '\n';
  }
  // SSDD 0.3 (2026-05-01), the version this writer follows. 0.3 adds only the distorted
  // spherical parametrization to 0.2, which this writer never uses, so 0.2 readers read the
  // file as well.
  os << "VERSION 0.3\n";
  if (!o.software.empty()) os << "SOFTWARE " << one_line(o.software) << '\n';
  if (!o.date.empty()) os << "DATE " << one_line(o.date) << '\n';
  const auto optional_entries = [&] {
    if (o.name_entry && !parts.name.empty()) os << "NAME " << one_line(parts.name) << '\n';
    switch (o.source) {
      case SsddSource::unset: break;
      case SsddSource::measured: os << "SOURCE_TYPE measured\n"; break;
      case SsddSource::generated: os << "SOURCE_TYPE generated\n"; break;
      case SsddSource::edited: os << "SOURCE_TYPE edited\n"; break;
    }
    if (!o.device.empty()) os << "DEVICE " << one_line(o.device) << '\n';
  };
  const auto bsdf = [&](const BsdfTable& t, std::string_view type) {
    os << "\nDATA_TYPE " << type << '\n';
    write_color(os, t.wavelengths());
    os << "PARAM_TYPE "
       << (t.param() == TableParam::spherical ? "spherical_coordinate_system"
           : t.param() == TableParam::specular ? "specular_coordinate_system"
                                               : "half_difference_coordinate_system")
       << '\n';
    const auto& red = t.reduction();
    if (red.bilateral || red.reciprocal)
      os << "REDUCTION_TYPE" << (red.bilateral ? " bilateral_symmetry" : "")
         << (red.reciprocal ? " reciprocity" : "") << '\n';
    os << "PARAM0_LIST " << list_text(t.axis(0)) << '\n';
    if (!t.isotropic()) os << "PARAM1_LIST " << list_text(t.axis(1)) << '\n';
    os << "PARAM2_LIST " << list_text(t.axis(2)) << '\n';
    os << "PARAM3_LIST " << list_text(t.axis(3)) << '\n';
    optional_entries();
    os << "DATA " << (binary ? "binary" : "ascii") << '\n';
    write_values(os, t.values(), t.channels(), binary, &t.axis(2), &t.axis(3),
                 t.nodes(0) * t.nodes(1));
  };
  const auto specular = [&](const SpecularTable& t, std::string_view type) {
    os << "\nDATA_TYPE " << type << '\n';
    write_color(os, t.wavelengths());
    os << "PARAM0_LIST " << list_text(t.theta_i()) << '\n';
    if (!t.phi_i().empty()) os << "PARAM1_LIST " << list_text(t.phi_i()) << '\n';
    optional_entries();
    os << "DATA " << (binary ? "binary" : "ascii") << '\n';
    write_values(os, t.values(), t.channels(), binary, nullptr, nullptr, 0);
  };
  if (parts.brdf) bsdf(*parts.brdf, "brdf");
  if (parts.btdf) bsdf(*parts.btdf, "btdf");
  if (parts.specular_reflectance) specular(*parts.specular_reflectance, "specular_reflectance");
  if (parts.specular_transmittance) specular(*parts.specular_transmittance, "specular_transmittance");
  if (!out) throw Error(Errc::io_error, "could not write the SSDD data");
  return warnings;
}

std::vector<std::string> write_ssdd(const std::string& path, const TabulatedParts& parts,
                                    const SsddWriteOptions& o) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw Error(Errc::io_error, fmt::format("cannot create '{}'", path), "path");
  auto warnings = write_ssdd(out, parts, o);
  out.close();
  if (!out) throw Error(Errc::io_error, fmt::format("cannot write '{}'", path), "path");
  return warnings;
}

}  // namespace gonio::twin
