// JsonWriter (json_writer.hpp).
#include "gonio/proto/json_writer.hpp"

#include <charconv>
#include <cmath>
#include <iterator>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace gonio {

void JsonWriter::separate() {
  if (out_.empty()) return;
  const char last = out_.back();
  if (last != '{' && last != '[' && last != ':' && last != ',') out_ += ',';
}

void JsonWriter::write_key(std::string_view key) {
  separate();
  write(key);
  out_ += ':';
}

JsonWriter& JsonWriter::begin_object(std::string_view key) {
  write_key(key);
  out_ += '{';
  return *this;
}

JsonWriter& JsonWriter::begin_object() {
  separate();
  out_ += '{';
  return *this;
}

JsonWriter& JsonWriter::end_object() {
  out_ += '}';
  return *this;
}

JsonWriter& JsonWriter::begin_array(std::string_view key) {
  write_key(key);
  out_ += '[';
  return *this;
}

JsonWriter& JsonWriter::begin_array() {
  separate();
  out_ += '[';
  return *this;
}

JsonWriter& JsonWriter::end_array() {
  out_ += ']';
  return *this;
}

JsonWriter& JsonWriter::raw_member(std::string_view key, std::string_view json_text) {
  write_key(key);
  out_ += json_text;
  return *this;
}

void JsonWriter::write(std::string_view s) {
  bool plain = true;
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u > 0x7e || c == '"' || c == '\\') {
      plain = false;
      break;
    }
  }
  if (plain) {
    out_ += '"';
    out_ += s;
    out_ += '"';
    return;
  }
  out_ += nlohmann::json(std::string(s)).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

void JsonWriter::write(bool b) { out_ += b ? "true" : "false"; }

void JsonWriter::write(std::nullptr_t) { out_ += "null"; }

void JsonWriter::write(double v) {
  if (!std::isfinite(v)) {
    out_ += "null";
    return;
  }
  // The shortest text that reads back as the same double; ".0" keeps an integral value a
  // double for typed readers, as nlohmann::json writes it.
  const auto start = out_.size();
  fmt::format_to(std::back_inserter(out_), "{}", v);
  if (out_.find_first_of(".eEn", start) == std::string::npos) out_ += ".0";
}

void JsonWriter::write_integer(std::int64_t v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out_.append(buf, r.ptr);
}

void JsonWriter::write_unsigned(std::uint64_t v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out_.append(buf, r.ptr);
}

}  // namespace gonio
