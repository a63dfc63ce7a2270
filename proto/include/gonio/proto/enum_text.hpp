// Enums as text — the one way an enum is named at the API, in config files and on the CLI.
//
// An enum E opts in with a table found by argument-dependent lookup, declared beside it:
//
//   enum class Axis { incidence, receive };
//   inline constexpr EnumNames<Axis, 2> kAxisNames{{{Axis::incidence, "incidence"},
//                                                   {Axis::receive, "receive"}}};
//   constexpr const auto& enum_names(Axis) { return kAxisNames; }
//
// and then gets to_text(e), from_text<E>(text) (empty when unknown) and
// parse_enum<E>(text, field), whose Error(invalid_argument) names the field and lists the
// allowed names, so every "not one of ..." message reads alike.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "gonio/proto/error.hpp"

namespace gonio {

template <typename E, std::size_t N>
using EnumNames = std::array<std::pair<E, std::string_view>, N>;

template <typename E>
constexpr std::string_view to_text(E e) noexcept {
  for (const auto& [v, name] : enum_names(E{}))
    if (v == e) return name;
  return "?";
}

template <typename E>
constexpr std::optional<E> from_text(std::string_view text) noexcept {
  for (const auto& [v, name] : enum_names(E{}))
    if (name == text) return v;
  return std::nullopt;
}

// "a, b, c": the allowed names in table order.
template <typename E>
std::string enum_name_list() {
  std::string out;
  for (const auto& [v, name] : enum_names(E{})) {
    if (!out.empty()) out += ", ";
    out += name;
  }
  return out;
}

// Throws Error::invalid(field, "'x' is not one of: a, b, c").
template <typename E>
E parse_enum(std::string_view text, std::string_view field) {
  if (const auto v = from_text<E>(text)) return *v;
  throw Error::invalid(std::string(field),
                       "'" + std::string(text) + "' is not one of: " + enum_name_list<E>());
}

}  // namespace gonio
