// Strict reading of JSON objects: typed fields, named errors, unknown keys rejected.
//
//   json_util::ObjectReader r(j, "sample");
//   auto name = r.required<std::string>("name");
//   auto tol  = r.optional<double>("tolerance", 0.02);
//   auto n    = r.optional_in<int>("repeats", 1, 1, 1000);   // bounded, inclusive
//   r.finish();   // throws if j has keys nobody asked for
//
// Errors are gonio::Error(invalid_argument) whose field is "<context>.<key>".
#pragma once

#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

#include <nlohmann/json.hpp>

#include "gonio/proto/error.hpp"

namespace gonio::json_util {

// Re-issues `e` with `prefix` put in front of its field ("points[3]" + "theta_r").
Error prefixed(const Error& e, std::string_view prefix);

std::string type_name(const nlohmann::json& j);

// An optional as JSON: the value, or null when absent.
template <typename T>
nlohmann::json or_null(const std::optional<T>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

template <typename T>
T get_as(const nlohmann::json& j, const std::string& field) {
  if constexpr (std::is_same_v<T, double>) {
    if (!j.is_number()) throw Error::invalid(field, "expected a number, got " + type_name(j));
    return j.template get<double>();
  } else if constexpr (std::is_same_v<T, bool>) {
    if (!j.is_boolean()) throw Error::invalid(field, "expected a boolean, got " + type_name(j));
    return j.template get<bool>();
  } else if constexpr (std::is_integral_v<T>) {
    if (!j.is_number_integer())
      throw Error::invalid(field, "expected an integer, got " + type_name(j));
    return j.template get<T>();
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (!j.is_string()) throw Error::invalid(field, "expected a string, got " + type_name(j));
    return j.template get<std::string>();
  } else {
    try {
      return j.template get<T>();
    } catch (const Error& e) {
      throw prefixed(e, field);
    } catch (const nlohmann::json::exception& e) {
      throw Error::invalid(field, e.what());
    }
  }
}

class ObjectReader {
 public:
  ObjectReader(const nlohmann::json& j, std::string context);

  bool has(const std::string& key) const { return j_.contains(key); }

  template <typename T>
  T required(const std::string& key) {
    used_.insert(key);
    const auto it = j_.find(key);
    if (it == j_.end()) throw Error::invalid(path(key), "is required");
    return get_as<T>(*it, path(key));
  }

  template <typename T>
  T optional(const std::string& key, T fallback) {
    used_.insert(key);
    const auto it = j_.find(key);
    if (it == j_.end() || it->is_null()) return fallback;
    return get_as<T>(*it, path(key));
  }

  // A number within [lo, hi] (NaN is outside every range): the one reader for bounded
  // config values, so that every bound is reported the same way (Error::out_of_range).
  template <typename T>
  T optional_in(const std::string& key, T fallback, T lo, T hi, std::string_view unit = {}) {
    return checked(key, optional<T>(key, fallback), lo, hi, unit);
  }
  template <typename T>
  T required_in(const std::string& key, T lo, T hi, std::string_view unit = {}) {
    return checked(key, required<T>(key), lo, hi, unit);
  }

  // Marks a key as consumed without reading it (the caller handles it itself).
  const nlohmann::json* raw(const std::string& key);

  // Throws naming the first key that no read asked for.
  void finish() const;

  std::string path(const std::string& key) const {
    return join_field(context_, key);
  }

 private:
  template <typename T>
  T checked(const std::string& key, T v, T lo, T hi, std::string_view unit) const {
    static_assert(std::is_arithmetic_v<T>);
    if (!(v >= lo && v <= hi))
      throw Error::out_of_range(path(key), static_cast<double>(v), static_cast<double>(lo),
                                static_cast<double>(hi), unit);
    return v;
  }

  const nlohmann::json& j_;
  std::string context_;
  std::set<std::string> used_;
};

}  // namespace gonio::json_util
