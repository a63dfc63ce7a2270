// Zemax / Radiant Imaging IS-SA "BSDF Data Interchange" files (.bsdf): reader and writer.
//
// Format: R. Rykowski, "BSDF Data Interchange File Format Specification" (Radiant Imaging /
// Zemax knowledge base, 2008; now "Zemax Tabular BSDF data file format"): a keyword header
// (Source, Symmetry, SpectralContent, ScatterType, SampleRotation, AngleOfIncidence,
// ScatterAzimuth, ScatterRadial, each list preceded by its count), then per spectral
// channel (Monochrome, or TristimulusX/Y/Z) a DataBegin … DataEnd block holding, for every
// sample rotation and angle of incidence, a "TIS <value>" line and one line per scatter
// azimuth with one BSDF value (sr⁻¹) per radial angle. Radial and azimuth angles are taken
// about the specular direction (the straight-through direction for BTDF); azimuth 0 points
// from it toward the sample normal, counter-clockwise. PlaneSymmetrical data give azimuths
// 0…180 only. That is exactly BsdfTable's specular parametrization (bilateral reduction).
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <numeric>
#include <sstream>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"
#include "gonio/twin/bsdf_io.hpp"
#include "tabulated/common.hpp"

namespace gonio::twin {
namespace {

enum class Symmetry { plane, asymmetrical, asymmetrical4d };

// Token cursor over the header: lists may continue over several lines.
class Tokens {
 public:
  explicit Tokens(tab::LineReader& r) : r_(r) {}
  bool next(std::string& tok) {
    while (pos_ >= toks_.size()) {
      if (!r_.next_content(line_)) return false;
      toks_.clear();
      for (auto t : tab::tokens(line_)) toks_.emplace_back(t);
      pos_ = 0;
    }
    tok = toks_[pos_++];
    return true;
  }
  std::string require(std::string_view what) {
    std::string t;
    if (!next(t)) r_.fail(fmt::format("end of file while reading {}", what), what);
    return t;
  }
  // True when the current line has no more tokens.
  bool line_done() const noexcept { return pos_ >= toks_.size(); }

 private:
  tab::LineReader& r_;
  std::string line_;
  std::vector<std::string> toks_;
  std::size_t pos_ = 0;
};

std::vector<double> read_list(Tokens& tk, tab::LineReader& r, std::string_view key, double lo,
                              double hi) {
  const std::size_t n = r.count(tk.require(key), key, BsdfTable::kMaxNodes);
  std::vector<double> v;
  v.reserve(std::min<std::size_t>(n, 1024));
  for (std::size_t i = 0; i < n; ++i) {
    const std::string t = tk.require(fmt::format("{} value {} of {}", key, i + 1, n));
    const double x = r.number(t, key);
    if (x < lo || x > hi)
      r.fail(fmt::format("{} {:g} is outside [{:g}, {:g}] deg", key, x, lo, hi), key);
    if (!v.empty() && !(x > v.back()))
      r.fail(fmt::format("{} {:g} does not increase on {:g}", key, x, v.back()), key);
    v.push_back(x);
  }
  return v;
}

struct Header {
  std::optional<Symmetry> symmetry;
  std::optional<bool> xyz;           // SpectralContent
  std::optional<bool> transmission;  // ScatterType
  std::optional<std::string> source;
  std::optional<std::vector<double>> rotation, incidence, azimuth, radial;
};

constexpr std::string_view kKeywords =
    "Source, Symmetry, SpectralContent, ScatterType, SampleRotation, AngleOfIncidence, "
    "ScatterAzimuth, ScatterRadial, Monochrome, TristimulusX, TristimulusY, TristimulusZ";

template <typename T>
void set_once(std::optional<T>& slot, T value, tab::LineReader& r, std::string_view key) {
  if (slot) r.fail(fmt::format("{} given twice", key), key);
  slot = std::move(value);
}

// Returns the first data label ("Monochrome", "TristimulusX", ...).
std::string read_header(tab::LineReader& r, Tokens& tk, Header& h) {
  std::string key;
  while (tk.next(key)) {
    using tab::iequals;
    if (iequals(key, "Source")) {
      set_once(h.source, tk.require("Source"), r, "Source");
    } else if (iequals(key, "Symmetry")) {
      const auto v = tk.require("Symmetry");
      Symmetry s{};
      if (iequals(v, "PlaneSymmetrical")) s = Symmetry::plane;
      else if (iequals(v, "Asymmetrical")) s = Symmetry::asymmetrical;
      else if (iequals(v, "Asymmetrical4D")) s = Symmetry::asymmetrical4d;
      else
        r.fail(fmt::format("Symmetry '{}' is not PlaneSymmetrical, Asymmetrical or "
                           "Asymmetrical4D", v), "Symmetry");
      set_once(h.symmetry, s, r, "Symmetry");
    } else if (iequals(key, "SpectralContent")) {
      const auto v = tk.require("SpectralContent");
      if (!iequals(v, "Monochrome") && !iequals(v, "XYZ"))
        r.fail(fmt::format("SpectralContent '{}' is not Monochrome or XYZ", v), "SpectralContent");
      set_once(h.xyz, iequals(v, "XYZ"), r, "SpectralContent");
    } else if (iequals(key, "ScatterType")) {
      const auto v = tk.require("ScatterType");
      if (!iequals(v, "BRDF") && !iequals(v, "BTDF"))
        r.fail(fmt::format("ScatterType '{}' is not BRDF or BTDF", v), "ScatterType");
      set_once(h.transmission, iequals(v, "BTDF"), r, "ScatterType");
    } else if (iequals(key, "SampleRotation")) {
      set_once(h.rotation, read_list(tk, r, "SampleRotation", -360, 360), r, "SampleRotation");
    } else if (iequals(key, "AngleOfIncidence")) {
      set_once(h.incidence, read_list(tk, r, "AngleOfIncidence", 0, 90), r, "AngleOfIncidence");
    } else if (iequals(key, "ScatterAzimuth")) {
      set_once(h.azimuth, read_list(tk, r, "ScatterAzimuth", 0, 360), r, "ScatterAzimuth");
    } else if (iequals(key, "ScatterRadial")) {
      set_once(h.radial, read_list(tk, r, "ScatterRadial", 0, 180), r, "ScatterRadial");
    } else if (iequals(key, "Monochrome") || iequals(key, "TristimulusX") ||
               iequals(key, "TristimulusY") || iequals(key, "TristimulusZ")) {
      if (!tk.line_done()) r.fail(fmt::format("'{}' must stand on its own line", key), key);
      return key;
    } else if (iequals(key, "DataBegin")) {
      r.fail("DataBegin before the Monochrome / Tristimulus label", "DataBegin");
    } else {
      r.fail(fmt::format("unknown keyword '{}'; expected one of {}", key, kKeywords), key);
    }
  }
  r.fail("end of file before the data section (Monochrome or TristimulusX label)");
}

void require_header(const tab::LineReader& r, const Header& h) {
  const auto missing = [&](bool ok, std::string_view key) {
    if (!ok) r.fail(fmt::format("the header lacks {}", key), key);
  };
  missing(h.symmetry.has_value(), "Symmetry");
  missing(h.xyz.has_value(), "SpectralContent");
  missing(h.transmission.has_value(), "ScatterType");
  missing(h.incidence.has_value(), "AngleOfIncidence");
  missing(h.azimuth.has_value(), "ScatterAzimuth");
  missing(h.radial.has_value(), "ScatterRadial");
  if (h.rotation && h.rotation->size() > 1)
    r.unsupported(fmt::format("{} sample rotations (anisotropic data); only one is supported",
                              h.rotation->size()),
                  "SampleRotation");
  if (*h.symmetry == Symmetry::plane && h.azimuth->back() > 180)
    r.fail(fmt::format("PlaneSymmetrical data need ScatterAzimuth within [0, 180], got {:g}",
                       h.azimuth->back()),
           "ScatterAzimuth");
}

// One DataBegin … DataEnd block, values in file order (incidence, azimuth, radial).
std::vector<double> read_block(tab::LineReader& r, const Header& h, std::string_view label) {
  std::string line;
  if (!r.next_content(line)) r.fail(fmt::format("end of file after '{}'", label), "DataBegin");
  if (!tab::iequals(tab::LineReader::trimmed(line), "DataBegin"))
    r.fail(fmt::format("expected DataBegin after '{}', got '{}'", label,
                       tab::LineReader::trimmed(line)),
           "DataBegin");
  const std::size_t n_rot = h.rotation ? h.rotation->size() : 1;
  const std::size_t n_aoi = h.incidence->size(), n_az = h.azimuth->size(),
                    n_rad = h.radial->size();
  std::vector<double> values;
  values.reserve(std::min<std::size_t>(n_aoi * n_az * n_rad, 1 << 16));
  for (std::size_t rot = 0; rot < n_rot; ++rot)
    for (std::size_t i = 0; i < n_aoi; ++i) {
      if (!r.next_content(line))
        r.fail(fmt::format("end of file: {} block has {} of {} angles of incidence", label, i,
                           n_aoi), "TIS");
      const auto t = tab::tokens(line);
      if (t.empty() || !tab::iequals(t[0], "TIS"))
        r.fail(fmt::format("expected 'TIS <value>' for angle of incidence {:g}, got '{}'",
                           (*h.incidence)[i], tab::LineReader::trimmed(line)), "TIS");
      if (t.size() != 2) r.fail("TIS takes exactly one value", "TIS");
      if (r.number(t[1], "TIS") < 0) r.fail(fmt::format("TIS {} is negative", t[1]), "TIS");
      for (std::size_t a = 0; a < n_az; ++a) {
        if (!r.next_content(line))
          r.fail(fmt::format("end of file: angle of incidence {:g} has {} of {} azimuth rows",
                             (*h.incidence)[i], a, n_az), "ScatterAzimuth");
        const auto row = tab::tokens(line);
        if (row.size() != n_rad)
          r.fail(fmt::format("azimuth {:g} row has {} values, ScatterRadial declares {}",
                             (*h.azimuth)[a], row.size(), n_rad), "ScatterRadial");
        for (std::size_t k = 0; k < n_rad; ++k) {
          const double v = r.number(row[k], "BSDF value");
          if (v < 0 || v > BsdfTable::kMaxF)
            r.fail(fmt::format("BSDF value {} at azimuth {:g}, radial {:g} is {}", row[k],
                               (*h.azimuth)[a], (*h.radial)[k],
                               v < 0 ? "negative" : "beyond 1e12 sr^-1"),
                   "BSDF value");
          values.push_back(v);
        }
      }
    }
  if (!r.next_content(line)) r.fail(fmt::format("end of file: {} block lacks DataEnd", label), "DataEnd");
  if (!tab::iequals(tab::LineReader::trimmed(line), "DataEnd"))
    r.fail(fmt::format("expected DataEnd, got '{}' (more rows than the header declares?)",
                       tab::LineReader::trimmed(line)), "DataEnd");
  return values;
}

std::vector<double> default_radial() {
  return {0,  0.5, 1,  1.5, 2,  3,  4,  5,  6,  8,  10,  12.5, 15,  17.5, 20,  25, 30,
          35, 40,  45, 50,  60, 70, 80, 90, 100, 110, 120, 135, 150, 165, 180};
}

std::vector<double> range(double a, double b, double step) {
  std::vector<double> v;
  for (double x = a; x <= b + 1e-9; x += step) v.push_back(x);
  return v;
}

void check_option_list(const std::vector<double>& v, std::string_view field, double lo, double hi) {
  if (v.empty()) throw Error::invalid(std::string(field), "is empty");
  for (std::size_t i = 0; i < v.size(); ++i) {
    const auto f = fmt::format("{}[{}]", field, i);
    if (!std::isfinite(v[i]) || v[i] < lo || v[i] > hi) throw Error::out_of_range(f, v[i], lo, hi, " deg");
    if (i > 0 && !(v[i] > v[i - 1]))
      throw Error::invalid(f, fmt::format("{:g} does not increase on {:g}", v[i], v[i - 1]));
  }
}

}  // namespace

TabulatedParts read_issa(std::istream& in, std::string_view source) {
  tab::LineReader r(in, source);
  Tokens tk(r);
  Header h;
  std::string label = read_header(r, tk, h);
  require_header(r, h);
  // A size check before any data: the table must fit (values still grow only with input).
  if (h.incidence->size() * h.azimuth->size() > BsdfTable::kMaxValues / h.radial->size())
    r.fail("the declared grid exceeds the size limit", "ScatterRadial");

  const bool xyz = *h.xyz;
  std::vector<double> grey;
  bool seen[3] = {false, false, false};
  for (;;) {
    int channel = 0;
    if (xyz) {
      if (tab::iequals(label, "TristimulusX")) channel = 0;
      else if (tab::iequals(label, "TristimulusY")) channel = 1;
      else if (tab::iequals(label, "TristimulusZ")) channel = 2;
      else r.fail(fmt::format("'{}' data in an XYZ file", label), label);
    } else if (!tab::iequals(label, "Monochrome")) {
      r.fail(fmt::format("'{}' data in a Monochrome file", label), label);
    }
    if (seen[channel]) r.fail(fmt::format("'{}' block given twice", label), label);
    seen[channel] = true;
    auto block = read_block(r, h, label);
    if (channel == (xyz ? 1 : 0)) grey = std::move(block);
    const bool done = xyz ? (seen[0] && seen[1] && seen[2]) : true;
    std::string line;
    if (done) {
      if (r.next_content(line))
        r.fail(fmt::format("unexpected content after the last DataEnd: '{}'",
                           tab::LineReader::trimmed(line)));
      break;
    }
    if (!r.next_content(line)) r.fail("end of file: XYZ data need TristimulusX, Y and Z blocks");
    const auto t = tab::tokens(line);
    if (t.size() != 1) r.fail(fmt::format("expected a Tristimulus label, got '{}'", line));
    label = std::string(t[0]);
  }

  // File order is (incidence, azimuth, radial); the table wants p0 fastest, then p2, p3.
  const std::size_t n0 = h.incidence->size(), n2 = h.radial->size(), n3 = h.azimuth->size();
  std::vector<double> values(grey.size());
  for (std::size_t i0 = 0; i0 < n0; ++i0)
    for (std::size_t i3 = 0; i3 < n3; ++i3)
      for (std::size_t i2 = 0; i2 < n2; ++i2)
        values[(i3 * n2 + i2) * n0 + i0] = grey[(i0 * n3 + i3) * n2 + i2];

  TabulatedParts parts;
  try {
    BsdfTable table(TableParam::specular, {*h.incidence, {}, *h.radial, *h.azimuth}, {},
                    std::move(values), {*h.symmetry == Symmetry::plane, false});
    (*h.transmission ? parts.btdf : parts.brdf) = std::move(table);
  } catch (const Error& e) {
    throw Error(Errc::parse_error, fmt::format("{}: {}", source, e.what()), e.field());
  }
  return parts;
}

TabulatedParts read_issa(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(Errc::not_found, fmt::format("cannot open '{}'", path), "path");
  return read_issa(in, path);
}

namespace {

// The file's spectral content: one grey table per output channel (X, Y, Z or the weighted one).
std::vector<BsdfTable> output_channels(const BsdfTable& table, const IssaWriteOptions& o) {
  std::vector<BsdfTable> channels;
  if (o.xyz_weights) {
    for (int k = 0; k < 3; ++k)
      channels.push_back(table.weighted((*o.xyz_weights)[static_cast<std::size_t>(k)]));
    return channels;
  }
  std::vector<double> w = o.weights;
  if (w.empty()) w.assign(table.channels(), 1.0);
  if (w.size() != table.channels())
    throw Error::invalid("weights", fmt::format("has {} weights for {} channels", w.size(),
                                                table.channels()));
  const double sum = std::accumulate(w.begin(), w.end(), 0.0);
  if (!(sum > 0) || !std::isfinite(sum)) throw Error::invalid("weights", "must have a positive sum");
  for (auto& x : w) x /= sum;
  channels.push_back(table.weighted(w));
  return channels;
}

// The file's grid: the options' lists, else the table's own (a specular table written as it
// is) or the defaults.
struct IssaGrid {
  bool native = false;  // the table's own grid: its values are written as they are
  bool plane = false;   // PlaneSymmetrical: azimuths 0–180°
  std::vector<double> incidence, azimuth, radial;
};

IssaGrid issa_grid(const BsdfTable& table, const IssaWriteOptions& o) {
  IssaGrid g;
  g.native = table.param() == TableParam::specular && table.isotropic() && o.incidence.empty() &&
             o.azimuth.empty() && o.radial.empty();
  g.plane = table.reduction().bilateral ||
            (table.param() == TableParam::half_difference && table.isotropic() &&
             table.reduction().reciprocal);
  g.incidence = o.incidence, g.azimuth = o.azimuth, g.radial = o.radial;
  if (g.incidence.empty()) {
    if (table.param() == TableParam::half_difference) g.incidence = range(0, 80, 10);
    else g.incidence = table.axis(0);
  }
  if (g.azimuth.empty())
    g.azimuth = g.native ? table.axis(3) : g.plane ? range(0, 180, 5) : range(0, 355, 5);
  if (g.radial.empty()) g.radial = g.native ? table.axis(2) : default_radial();
  if (o.keep_gaps && o.radial.empty() && table.param() == TableParam::spherical) {
    // The in-plane nodes' distances from the specular direction: ahead of it (φo = 180°)
    // |θo − θi|, behind it through the normal (φo = 0°) θi + θo.
    for (const double ti : table.axis(0))
      for (const double to : table.axis(2)) {
        g.radial.push_back(std::abs(to - ti));
        if (ti + to <= 180) g.radial.push_back(ti + to);
      }
    std::sort(g.radial.begin(), g.radial.end());
    g.radial.erase(std::unique(g.radial.begin(), g.radial.end(), [](double a, double b) { return b - a < 1e-9; }),
                   g.radial.end());
  }
  check_option_list(g.incidence, "incidence", 0, 90);
  check_option_list(g.azimuth, "azimuth", 0, g.plane ? 180 : 360);
  check_option_list(g.radial, "radial", 0, 180);
  return g;
}

// The file's own tables: the values exactly as written, so that TIS is the integral of
// what a reader interpolates, not of the table they were resampled from.
std::vector<BsdfTable> file_tables(const std::vector<BsdfTable>& channels, const IssaGrid& g,
                                   bool keep_gaps) {
  std::vector<BsdfTable> file;
  for (const BsdfTable& t : channels) {
    if (g.native) {
      file.push_back(t);
      continue;
    }
    std::vector<double> v(g.incidence.size() * g.radial.size() * g.azimuth.size());
    double f = 0;
    for (std::size_t i = 0; i < g.incidence.size(); ++i) {
      const double th = g.incidence[i] * kDegToRad;
      const Vec3 wi{-std::sin(th), 0, std::cos(th)};
      const auto frame = tab::MirrorFrame::of(wi);
      for (std::size_t a = 0; a < g.azimuth.size(); ++a)
        for (std::size_t j = 0; j < g.radial.size(); ++j) {
          // Beyond the horizon the file still needs a value; the one at the horizon along
          // the same azimuth keeps interpolation near grazing angles unbiased.
          const Vec3 wo = frame.direction_above(g.radial[j] * kDegToRad, g.azimuth[a] * kDegToRad);
          if (keep_gaps && !t.covers(t.coords(wi, wo))) f = 0;
          else t.eval(wi, wo, {&f, 1});
          v[(a * g.radial.size() + j) * g.incidence.size() + i] = f;
        }
    }
    file.emplace_back(TableParam::specular, BsdfTable::Axes{g.incidence, {}, g.radial, g.azimuth},
                      std::vector<double>{}, std::move(v), TableReduction{g.plane, false});
  }
  return file;
}

std::string tab_list(const std::vector<double>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? "\t" : "") + text::format_number(v[i]);
  return s;
}

// The header, and each channel's block of TIS and values per angle of incidence.
void write_issa_text(std::ostream& os, const std::vector<BsdfTable>& file,
                     const std::vector<std::vector<double>>& tis, const IssaGrid& g,
                     bool transmission, bool xyz, const std::string& comment) {
  if (!comment.empty()) {
    std::istringstream cs(comment);
    for (std::string line; std::getline(cs, line);) os << "# " << line << '\n';
  }
  os << "Source\tMeasured\n"
     << "Symmetry\t" << (g.plane ? "PlaneSymmetrical" : "Asymmetrical") << '\n'
     << "SpectralContent\t" << (xyz ? "XYZ" : "Monochrome") << '\n'
     << "ScatterType\t" << (transmission ? "BTDF" : "BRDF") << '\n'
     << "SampleRotation\t1\n0\n"
     << "AngleOfIncidence\t" << g.incidence.size() << '\n' << tab_list(g.incidence) << '\n'
     << "ScatterAzimuth\t" << g.azimuth.size() << '\n' << tab_list(g.azimuth) << '\n'
     << "ScatterRadial\t" << g.radial.size() << '\n' << tab_list(g.radial) << "\n\n";
  static constexpr const char* kLabels[3] = {"TristimulusX", "TristimulusY", "TristimulusZ"};
  for (std::size_t k = 0; k < file.size(); ++k) {
    const BsdfTable& t = file[k];
    os << (xyz ? kLabels[k] : "Monochrome") << "\nDataBegin\n";
    for (std::size_t i = 0; i < g.incidence.size(); ++i) {
      os << "TIS " << fmt::format("{:.6g}", tis[k][i]) << '\n';
      fmt::memory_buffer buf;
      for (std::size_t a = 0; a < g.azimuth.size(); ++a) {
        for (std::size_t j = 0; j < g.radial.size(); ++j) {
          if (j) buf.push_back('\t');
          fmt::format_to(std::back_inserter(buf), "{}", t.at(i, 0, j, a, 0));
        }
        buf.push_back('\n');
      }
      os.write(buf.data(), static_cast<std::streamsize>(buf.size()));
    }
    os << "DataEnd\n";
  }
}

}  // namespace

std::vector<std::string> write_issa(std::ostream& out, const BsdfTable& table, bool transmission,
                                    const IssaWriteOptions& o) {
  if (table.empty()) throw Error::invalid("table", "is empty");
  if (!table.isotropic())
    throw Error(Errc::unsupported,
                "an IS-SA file holds one sample rotation; an anisotropic table needs .ssdd",
                "table");
  const auto channels = output_channels(table, o);
  const auto g = issa_grid(table, o);
  const auto file = file_tables(channels, g, o.keep_gaps);
  // TIS per channel and angle of incidence; an energy check on the luminance channel (Y, or
  // the monochrome one): above 1 is named in the file and returned.
  std::vector<std::vector<double>> tis(file.size(), std::vector<double>(g.incidence.size()));
  for (std::size_t k = 0; k < file.size(); ++k)
    for (std::size_t i = 0; i < g.incidence.size(); ++i)
      tis[k][i] = table_albedo(file[k], g.incidence[i])[0];
  std::vector<std::string> warnings;
  const auto& lum = tis[o.xyz_weights ? 1 : 0];
  for (std::size_t i = 0; i < g.incidence.size(); ++i)
    if (lum[i] > 1 + 1e-3)
      warnings.push_back(fmt::format(
          "directional {} {:.4g} exceeds 1 at AngleOfIncidence {:g}: the table {} more light "
          "than falls on it", transmission ? "transmittance" : "reflectance", lum[i],
          g.incidence[i], transmission ? "transmits" : "reflects"));

  std::string comment = o.comment;
  for (const auto& w : warnings) comment += (comment.empty() ? "" : "\n") + ("warning: " + w);
  write_issa_text(out, file, tis, g, transmission, o.xyz_weights.has_value(), comment);
  if (!out) throw Error(Errc::io_error, "could not write the IS-SA data");
  return warnings;
}

std::vector<std::string> write_issa(const std::string& path, const BsdfTable& table,
                                    bool transmission, const IssaWriteOptions& options) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw Error(Errc::io_error, fmt::format("cannot create '{}'", path), "path");
  auto warnings = write_issa(out, table, transmission, options);
  out.close();
  if (!out) throw Error(Errc::io_error, fmt::format("cannot write '{}'", path), "path");
  return warnings;
}

}  // namespace gonio::twin
