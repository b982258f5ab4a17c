/**
 * @file invocation.h
 * @brief The values a caller binds to a contract's parameters, as text (the way a plan step carries them), and
 *        the checks that turn them into an interface's typed fields.
 *
 * A component's generic command `~invoke` (component.h) runs any of its contracted commands and operations from
 * such bindings: the interface's binder reads the values it needs through an Invocation and builds the typed goal
 * or request. Every problem is a ValidationError whose sentence names the operator and the parameter: a name the
 * contract does not declare, a value missing, left open ("?x") or empty, not a number, not finite, out of range,
 * too long. Settings are values beside the contract (e.g. `pose_source`, `max_age`) that a caller offers to any
 * interface: a binder reads those it knows and the rest are ignored.
 */
#pragma once

#include <cstddef>
#include <set>
#include <string>
#include <vector>

#include "xpersif/core/common/pose2d.h"

namespace xpersif::core {

class Invocation {
 public:
  static constexpr std::size_t kMaxEntries = 64;     ///< parameters (and settings) at most
  static constexpr std::size_t kMaxValueLength = 1024;

  /**
   * @param operator_name the contract's name, for sentences (e.g. "push")
   * @param declared the contract's parameters (e.g. {"?object", "?side"})
   * @param parameters names bound by the caller, parallel to @p values; each must be one of @p declared
   * @param settings names beside the contract, parallel to @p setting_values
   * @throws ValidationError when the lists differ in length, are too long, repeat a name, name an undeclared
   *         parameter, or a value is longer than kMaxValueLength
   */
  Invocation(std::string operator_name, std::vector<std::string> declared, std::vector<std::string> parameters,
             std::vector<std::string> values, std::vector<std::string> settings = {},
             std::vector<std::string> setting_values = {});

  const std::string& operatorName() const { return operator_name_; }
  /// True when the caller bound @p parameter (to anything, even an open value).
  bool has(const std::string& parameter) const;

  /// The bound value of @p parameter; throws ValidationError when it is missing, empty or open ("?x").
  const std::string& text(const std::string& parameter) const;
  /// The value as a finite number (throws naming the parameter otherwise).
  double number(const std::string& parameter) const;
  /// The value as a number in [lo, hi].
  double number(const std::string& parameter, double lo, double hi) const;
  /// The value as a pose "(x, y, yaw)" (parentheses optional), every part finite, yaw within +-kMaxHeading.
  Pose2D pose(const std::string& parameter) const;

  /// A setting's value, or @p fallback when the caller did not give it.
  std::string setting(const std::string& name, const std::string& fallback) const;
  /// A setting as a number in [lo, hi], or @p fallback when not given.
  double settingNumber(const std::string& name, double fallback, double lo, double hi) const;

 private:
  const std::string* find(const std::vector<std::string>& names, const std::vector<std::string>& values,
                          const std::string& name) const;
  std::string field(const std::string& parameter) const;

  std::string operator_name_;
  std::vector<std::string> declared_, parameters_, values_, settings_, setting_values_;
};

/// @p text as a finite number; throws ValidationError "<field> is '<text>', not a number" (or not finite).
double parseNumber(const std::string& field, const std::string& text);
/// "(x, y, yaw)" (also without parentheses) into a pose; throws ValidationError naming @p field otherwise.
Pose2D parsePose(const std::string& field, const std::string& text);

}  // namespace xpersif::core
