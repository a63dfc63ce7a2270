#include "gonio/proto/error.hpp"

#include <array>
#include <utility>

#include <fmt/format.h>

namespace gonio {
namespace {

constexpr std::array<std::pair<Errc, std::string_view>, 18> kIds{{
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

Error Error::invalid(std::string field, std::string message) {
  auto msg = field.empty() ? message : fmt::format("{}: {}", field, message);
  return Error(Errc::invalid_argument, std::move(msg), std::move(field));
}

}  // namespace gonio
