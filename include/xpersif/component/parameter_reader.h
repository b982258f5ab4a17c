/**
 * @file parameter_reader.h
 * @brief Reading a component's parameters through its declarations (core/parameters.h).
 *
 * `ParameterReader::get<T>(name)` returns the value set under the private namespace, or the declared default,
 * after checking it against the declaration: a value of the wrong type ("~seed is set but is not an int") or
 * out of range is a core::ValidationError naming the parameter, so configure fails with that sentence instead of
 * silently falling back to the default as `NodeHandle::param` does. Reading an undeclared name is a
 * std::logic_error: every parameter is declared once.
 */
#pragma once

#include <ros/ros.h>

#include <cmath>
#include <map>
#include <string>
#include <type_traits>
#include <vector>

#include "xpersif/core/common/parameters.h"
#include "xpersif/core/common/validation.h"

namespace xpersif {

class ParameterReader {
 public:
  /// @param label how sentences name the namespace: "~", or "~part/" for an aggregate's part
  ParameterReader(const ros::NodeHandle& private_nh, const core::ParameterTable& table, std::string label = "~")
      : pnh_(private_nh), table_(table), label_(std::move(label)) {}

  /// The value of ~name, or its declared default.
  template <class T>
  T get(const std::string& name) const {
    const core::ParameterSpec& spec = table_.at(name);
    requireType<T>(spec);
    T value{};
    if (read(spec, value)) return value;
    if constexpr (std::is_same_v<T, std::map<std::string, double>>) {
      return value;  // a dictionary's default is empty (its meaning says what that stands for)
    } else {
      const T* fallback = std::get_if<T>(&spec.default_value);
      if (!fallback) throw std::logic_error(table_.owner() + " reads ~" + name + " without a default to fall back on");
      return *fallback;
    }
  }

  /// The value of ~name, or @p fallback (a default worked out at configure time).
  template <class T>
  T get(const std::string& name, const T& fallback) const {
    const core::ParameterSpec& spec = table_.at(name);
    requireType<T>(spec);
    T value{};
    if (!read(spec, value)) value = fallback;
    return value;
  }

  /// Whether ~name is set (it must be declared).
  bool has(const std::string& name) const {
    table_.at(name);
    return pnh_.hasParam(name);
  }

 private:
  template <class T>
  static void requireType(const core::ParameterSpec& spec) {
    using Type = core::ParameterSpec::Type;
    Type expected;
    if constexpr (std::is_same_v<T, bool>) expected = Type::Bool;
    else if constexpr (std::is_same_v<T, int>) expected = Type::Int;
    else if constexpr (std::is_same_v<T, double>) expected = Type::Double;
    else if constexpr (std::is_same_v<T, std::string>) expected = Type::String;
    else if constexpr (std::is_same_v<T, std::vector<std::string>>) expected = Type::StringList;
    else if constexpr (std::is_same_v<T, std::vector<double>>) expected = Type::DoubleList;
    else if constexpr (std::is_same_v<T, std::map<std::string, double>>) expected = Type::Dictionary;
    else static_assert(sizeof(T) == 0, "a parameter type ParameterReader does not read");
    if (spec.type != expected) throw std::logic_error("~" + spec.name + " is declared as " + spec.typeName() + " but read as another type");
  }

  /// False when ~name is not set; throws ValidationError when it is set but wrong.
  template <class T>
  bool read(const core::ParameterSpec& spec, T& value) const {
    if (!pnh_.hasParam(spec.name)) return false;
    if (!pnh_.getParam(spec.name, value)) {
      throw core::ValidationError(label_ + spec.name + " (" + pnh_.resolveName(spec.name) + ") is set but is not of type " +
                                  spec.typeName() + (spec.meaning.empty() ? "" : ": " + spec.meaning));
    }
    if constexpr (std::is_same_v<T, std::map<std::string, double>>) {
      if (std::isfinite(spec.max)) core::requireMaxSize(label_ + spec.name, value.size(), static_cast<std::size_t>(spec.max));
      for (const auto& [key, number] : value) core::requireFinite(label_ + spec.name + "/" + key, number);
    } else {
      core::throwIfInvalid(core::checkParameter(spec, core::ParameterSpec::Value(value), label_ + spec.name));
    }
    return true;
  }

  ros::NodeHandle pnh_;
  const core::ParameterTable& table_;
  std::string label_;
};

/// The names set directly under @p private_nh's namespace (the first level below it), from the master.
std::vector<std::string> parametersSetUnder(const ros::NodeHandle& private_nh);

}  // namespace xpersif
