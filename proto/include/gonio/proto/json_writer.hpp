// JsonWriter: JSON text written straight to a string, for the answers polled many times a
// second (system.info and what it reports). Building a nlohmann::json tree to dump it at
// once costs an allocation per member and per key; this appends the text and nothing else.
//
// The writer only separates and escapes: keys and nesting are the caller's to get right,
// and the tests parse what it writes. Non-finite numbers are written as null, as
// nlohmann::json does; strings with anything but printable ASCII go through nlohmann's
// escaping (invalid UTF-8 replaced, as every gonio answer does).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>

namespace gonio {

class JsonWriter {
 public:
  // Appends to `out`, which may already hold an open object or array.
  explicit JsonWriter(std::string& out) : out_(out) {}

  // Containers: as a member (with a key) or as an element (without).
  JsonWriter& begin_object(std::string_view key);
  JsonWriter& begin_object();
  JsonWriter& end_object();
  JsonWriter& begin_array(std::string_view key);
  JsonWriter& begin_array();
  JsonWriter& end_array();

  // Members. Integers and doubles are distinct: a double always reads back as one ("2.0").
  template <class T>
  JsonWriter& member(std::string_view key, const T& value) {
    write_key(key);
    write(value);
    return *this;
  }
  // A member whose value is already JSON text, spliced in unchanged.
  JsonWriter& raw_member(std::string_view key, std::string_view json_text);

  // An element of the enclosing array.
  template <class T>
  JsonWriter& element(const T& value) {
    separate();
    write(value);
    return *this;
  }

  const std::string& text() const noexcept { return out_; }

 private:
  void separate();  // a comma unless the container was just opened
  void write_key(std::string_view key);
  void write(std::string_view s);
  void write(const std::string& s) { write(std::string_view(s)); }
  void write(const char* s) { write(std::string_view(s)); }
  void write(bool b);
  void write(std::nullptr_t);
  void write(double v);
  void write(float v) { write(static_cast<double>(v)); }
  void write_integer(std::int64_t v);
  void write_unsigned(std::uint64_t v);
  template <class T>
  void write(const std::optional<T>& v) {
    if (v) write(*v);
    else write(nullptr);
  }
  template <class T>
    requires(std::is_integral_v<T> && !std::is_same_v<T, bool>)
  void write(T v) {
    if constexpr (std::is_signed_v<T>) write_integer(static_cast<std::int64_t>(v));
    else write_unsigned(static_cast<std::uint64_t>(v));
  }

  std::string& out_;
};

}  // namespace gonio
