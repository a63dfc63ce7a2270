// gonio::Error: the Errc ids and the message factories.
#include "gonio/proto/error.hpp"

#include <array>
#include <utility>

#include <fmt/format.h>

namespace gonio {
namespace {

constexpr std::array<std::pair<Errc, std::string_view>, 19> kIds{{
    {Errc::invalid_argument, "invalid_argument"},
    {Errc::out_of_range, "out_of_range"},
    {Errc::parse_error, "parse_error"},
    {Errc::not_found, "not_found"},
    {Errc::unsupported, "unsupported"},
    {Errc::io_error, "io_error"},
    {Errc::timeout, "timeout"},
    {Errc::disconnected, "disconnected"},
    {Errc::device_alarm, "device_alarm"},
    {Errc::protocol_error, "protocol_error"},
    {Errc::limit_violation, "limit_violation"},
    {Errc::busy, "busy"},
    {Errc::saturated, "saturated"},
    {Errc::invalid_state, "invalid_state"},
    {Errc::unauthorized, "unauthorized"},
    {Errc::forbidden, "forbidden"},
    {Errc::plan_rejected, "plan_rejected"},
    {Errc::storage_unavailable, "storage_unavailable"},
    {Errc::internal, "internal"},
}};

}  // namespace

std::string_view errc_id(Errc code) noexcept {
  for (const auto& [c, id] : kIds)
    if (c == code) return id;
  return "internal";
}

Errc errc_from_id(std::string_view id) noexcept {
  for (const auto& [c, s] : kIds)
    if (s == id) return c;
  return Errc::internal;
}

std::string join_field(std::string_view prefix, std::string_view field) {
  if (prefix.empty()) return std::string(field);
  if (field.empty()) return std::string(prefix);
  if (field.front() == '[') return fmt::format("{}{}", prefix, field);
  return fmt::format("{}.{}", prefix, field);
}

Error::Error(Errc code, std::string message, std::string field)
    : std::runtime_error(std::move(message)), code_(code), field_(std::move(field)) {}

Error Error::out_of_range(std::string field, double value, double lo, double hi,
                          std::string_view unit) {
  auto msg = fmt::format("{} = {:g}{} is outside the allowed range [{:g}, {:g}]{}", field,
                         value, unit, lo, hi, unit);
  return Error(Errc::out_of_range, std::move(msg), std::move(field));
}

namespace {

// "<field>: <text>", or the text alone when there is no field.
std::string with_field(const std::string& field, std::string_view text) {
  return field.empty() ? std::string(text) : fmt::format("{}: {}", field, text);
}

}  // namespace

Error Error::invalid(std::string field, std::string message) {
  auto msg = with_field(field, message);
  return Error(Errc::invalid_argument, std::move(msg), std::move(field));
}

Error Error::not_found(std::string field, std::string_view what) {
  auto msg = with_field(field, fmt::format("{} does not exist", what));
  return Error(Errc::not_found, std::move(msg), std::move(field));
}

Error Error::exists(std::string field, std::string_view what) {
  auto msg = with_field(field, fmt::format("{} already exists", what));
  return Error(Errc::invalid_state, std::move(msg), std::move(field));
}

Error Error::wrong_state(std::string field, std::string_view why) {
  auto msg = with_field(field, why);
  return Error(Errc::invalid_state, std::move(msg), std::move(field));
}

Error Error::forbidden(std::string_view action, std::string_view needed, std::string_view who,
                       std::string_view has) {
  return Error(Errc::forbidden, fmt::format("{} needs the {} role; '{}' has {}", action, needed, who, has));
}

}  // namespace gonio
