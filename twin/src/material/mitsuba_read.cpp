// Reading back the material of a scene written by mitsuba_scene: the inverse of its mapping
// (mitsuba.cpp), so that a test can build the spec the XML stands for and have the twin
// predict both. A small reader of the XML that writer produces (elements, attributes in
// double quotes, comments and the declaration), not a general XML parser.
#include <memory>

#include <fmt/format.h>

#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"
#include "gonio/twin/material.hpp"

namespace gonio::twin::material {
namespace {

struct Element {
  std::string tag;
  std::vector<std::pair<std::string, std::string>> attrs;
  std::vector<Element> children;

  std::string attr(std::string_view name) const {
    for (const auto& [k, v] : attrs)
      if (k == name) return v;
    return {};
  }
  // The value attribute of the child <type name="name" value=...>, empty when absent.
  std::string param(std::string_view name) const {
    for (const auto& c : children)
      if (c.attr("name") == name) return c.attr("value");
    return {};
  }
  std::vector<const Element*> bsdfs() const {
    std::vector<const Element*> v;
    for (const auto& c : children)
      if (c.tag == "bsdf") v.push_back(&c);
    return v;
  }
};

[[noreturn]] void bad(std::string_view what) {
  throw Error(Errc::parse_error, fmt::format("Mitsuba XML: {}", what), "xml");
}

class Reader {
 public:
  explicit Reader(std::string_view s) : s_(s) {}

  Element document() {
    Element root{"#document", {}, {}};
    children(root);
    return root;
  }

 private:
  void skip_space() {
    while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) ++i_;
  }
  void skip_past(std::string_view end) {
    const auto p = s_.find(end, i_);
    if (p == std::string_view::npos) bad(fmt::format("unterminated '{}'", end));
    i_ = p + end.size();
  }
  std::string name() {
    const auto b = i_;
    while (i_ < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[i_])) || s_[i_] == '_' || s_[i_] == '-')) ++i_;
    if (i_ == b) bad(fmt::format("a name expected at byte {}", b));
    return std::string(s_.substr(b, i_ - b));
  }
  // Children of `parent` until its closing tag (or the end, for the document).
  void children(Element& parent) {
    for (;;) {
      const auto lt = s_.find('<', i_);
      if (lt == std::string_view::npos) {
        if (parent.tag != "#document") bad("missing </" + parent.tag + ">");
        return;
      }
      i_ = lt + 1;
      if (s_.substr(i_, 3) == "!--") { skip_past("-->"); continue; }
      if (s_.substr(i_, 1) == "?") { skip_past("?>"); continue; }
      if (s_.substr(i_, 1) == "/") {
        ++i_;
        if (name() != parent.tag) bad("mismatched closing tag in <" + parent.tag + ">");
        skip_past(">");
        return;
      }
      Element e{name(), {}, {}};
      bool open = true;
      for (;;) {
        skip_space();
        if (i_ >= s_.size()) bad("unterminated tag <" + e.tag + ">");
        if (s_[i_] == '/') { skip_past(">"); open = false; break; }
        if (s_[i_] == '>') { ++i_; break; }
        auto key = name();
        skip_space();
        if (s_.substr(i_, 2) != "=\"") bad("attribute " + key + " needs =\"…\"");
        i_ += 2;
        const auto q = s_.find('"', i_);
        if (q == std::string_view::npos) bad("unterminated attribute " + key);
        e.attrs.emplace_back(std::move(key), std::string(s_.substr(i_, q - i_)));
        i_ = q + 1;
      }
      if (open) children(e);
      parent.children.push_back(std::move(e));
    }
  }

  std::string_view s_;
  std::size_t i_ = 0;
};

const Element* find_id(const Element& e, std::string_view id) {
  if (e.attr("id") == id) return &e;
  for (const auto& c : e.children)
    if (const auto* f = find_id(c, id)) return f;
  return nullptr;
}

// A spectrum value scaled by `w`, back in the spec syntax ("400:0.1,700:0.2" or "0.5").
std::string scaled(const std::string& value, double w, std::string_view what) {
  if (value.empty()) bad(fmt::format("{} is missing", what));
  std::string out;
  for (const auto item : text::split(value, ',')) {
    const auto parts = text::split(item, ':');
    if (parts.size() == 1) return text::format_number(text::parse_double(what, parts[0]) * w);
    out += (out.empty() ? "" : ",") + std::string(text::trim(parts[0])) + ":" +
           text::format_number(text::parse_double(what, parts[1]) * w);
  }
  return out;
}

double number(const Element& e, std::string_view name) {
  const auto v = e.param(name);
  if (v.empty()) bad(fmt::format("<{}> has no '{}'", e.attr("type"), name));
  return text::parse_double(name, v);
}

// The spec of one leaf plugin whose contribution is weighted by `w`.
std::string leaf(const Element& e, double w) {
  const auto type = e.attr("type");
  const auto unit_weight = [&](double s) {
    if (std::abs(w * s - 1) > 1e-12)
      throw Error(Errc::unsupported, fmt::format("Mitsuba XML: <{}> weighted by {} has no twin spec", type, w * s), "xml");
  };
  const auto scale_of = [&](std::string_view key) {
    const auto v = e.param(key);
    return v.empty() ? 1.0 : text::parse_double(key, v);
  };
  if (type == "diffuse") return "lambert:albedo=" + scaled(e.param("reflectance"), w, "reflectance");
  if (type == "conductor" && e.param("material") == "none")
    return "mirror:reflectance=" + scaled(e.param("specular_reflectance"), w, "specular_reflectance");
  const auto alpha = text::format_number(number(e, "alpha"));
  if (type == "roughconductor") {
    unit_weight(scale_of("specular_reflectance"));
    const auto name = e.param("distribution") == "beckmann" ? "beckmann" : "conductor";
    return fmt::format("{}:alpha={},eta={},k={}", name, alpha, scaled(e.param("eta"), 1, "eta"),
                       scaled(e.param("k"), 1, "k"));
  }
  if (type == "roughdielectric") {
    unit_weight(scale_of("specular_reflectance"));
    return fmt::format("dielectric:alpha={},ior={}", alpha,
                       text::format_number(number(e, "int_ior") / number(e, "ext_ior")));
  }
  if (type == "roughplastic") {
    unit_weight(1);
    return fmt::format("plastic:albedo={},alpha={},ior={}", scaled(e.param("diffuse_reflectance"), 1, "diffuse_reflectance"),
                       alpha, text::format_number(number(e, "int_ior") / number(e, "ext_ior")));
  }
  throw Error(Errc::unsupported, fmt::format("Mitsuba XML: plugin '{}' has no twin spec", type), "xml");
}

void collect(const Element& e, double w, std::vector<std::string>& lobes) {
  const auto type = e.attr("type");
  const auto kids = e.bsdfs();
  if (type == "twosided") {
    if (kids.size() != 1) bad("twosided needs one nested bsdf");
    return collect(*kids[0], w, lobes);
  }
  if (type == "blendbsdf") {
    if (kids.size() != 2) bad("blendbsdf needs two nested bsdfs");
    const double t = number(e, "weight");
    collect(*kids[0], w * (1 - t), lobes);
    collect(*kids[1], w * t, lobes);
    return;
  }
  lobes.push_back(leaf(e, w));
}

}  // namespace

std::string spec_from_mitsuba(std::string_view xml) {
  const auto doc = Reader(xml).document();
  const auto* m = find_id(doc, "material");
  if (m == nullptr || m->tag != "bsdf") bad("no <bsdf id=\"material\">");
  std::vector<std::string> lobes;
  collect(*m, 1, lobes);
  std::string spec;
  for (const auto& l : lobes) spec += (spec.empty() ? "" : "+") + l;
  return spec;
}

}  // namespace gonio::twin::material
