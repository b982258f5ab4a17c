#include "xpersif/core/common/invocation.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "xpersif/core/common/validation.h"

namespace xpersif::core {

namespace {
std::string list(const std::vector<std::string>& names) {
  if (names.empty()) return "none";
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

void checkNames(const std::string& op, const std::string& what, const std::string& values_field,
                const std::vector<std::string>& names, const std::vector<std::string>& values) {
  if (names.size() != values.size()) {
    throw ValidationError(op + ": " + std::to_string(names.size()) + " " + what + " but " +
                          std::to_string(values.size()) + " " + values_field);
  }
  requireMaxSize(op + " " + what, names.size(), Invocation::kMaxEntries);
  std::set<std::string> seen;
  for (std::size_t i = 0; i < names.size(); ++i) {
    requireMaxLength(op + " " + what + "[" + std::to_string(i) + "]", names[i], 128);
    requireMaxLength(op + " " + names[i], values[i], Invocation::kMaxValueLength);
    if (!seen.insert(names[i]).second) throw ValidationError(op + ": " + names[i] + " is given twice");
  }
}
}  // namespace

Invocation::Invocation(std::string operator_name, std::vector<std::string> declared, std::vector<std::string> parameters,
                       std::vector<std::string> values, std::vector<std::string> settings,
                       std::vector<std::string> setting_values)
    : operator_name_(std::move(operator_name)),
      declared_(std::move(declared)),
      parameters_(std::move(parameters)),
      values_(std::move(values)),
      settings_(std::move(settings)),
      setting_values_(std::move(setting_values)) {
  checkNames(operator_name_, "parameters", "values", parameters_, values_);
  checkNames(operator_name_, "settings", "setting_values", settings_, setting_values_);
  for (const auto& p : parameters_) {
    if (std::find(declared_.begin(), declared_.end(), p) == declared_.end()) {
      throw ValidationError(operator_name_ + ": " + (p.empty() ? "''" : p) + " is not a parameter of its contract (" +
                            list(declared_) + ")");
    }
  }
}

const std::string* Invocation::find(const std::vector<std::string>& names, const std::vector<std::string>& values,
                                    const std::string& name) const {
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) return &values[i];
  }
  return nullptr;
}

std::string Invocation::field(const std::string& parameter) const { return operator_name_ + " " + parameter; }

bool Invocation::has(const std::string& parameter) const { return find(parameters_, values_, parameter) != nullptr; }

const std::string& Invocation::text(const std::string& parameter) const {
  const std::string* value = find(parameters_, values_, parameter);
  if (!value) throw ValidationError(operator_name_ + " needs " + parameter + ", which is not given");
  if (value->empty()) throw ValidationError(field(parameter) + " is empty");
  if ((*value)[0] == '?') {
    throw ValidationError(field(parameter) + " is left open ('" + *value + "'); bind it before invoking");
  }
  return *value;
}

double Invocation::number(const std::string& parameter) const { return parseNumber(field(parameter), text(parameter)); }

double Invocation::number(const std::string& parameter, double lo, double hi) const {
  const double value = number(parameter);
  requireInRange(field(parameter), value, lo, hi);
  return value;
}

Pose2D Invocation::pose(const std::string& parameter) const {
  const Pose2D p = parsePose(field(parameter), text(parameter));
  throwIfInvalid(checkHeading(field(parameter) + " yaw", p.yaw));
  return p;
}

std::string Invocation::setting(const std::string& name, const std::string& fallback) const {
  const std::string* value = find(settings_, setting_values_, name);
  return value ? *value : fallback;
}

double Invocation::settingNumber(const std::string& name, double fallback, double lo, double hi) const {
  const std::string* value = find(settings_, setting_values_, name);
  if (!value) return fallback;
  const double number = parseNumber(operator_name_ + " setting " + name, *value);
  requireInRange(operator_name_ + " setting " + name, number, lo, hi);
  return number;
}

double parseNumber(const std::string& field, const std::string& text) {
  std::size_t used = 0;
  double value = NAN;
  try {
    value = std::stod(text, &used);
  } catch (const std::out_of_range&) {
    throw ValidationError(field + " is '" + text + "', beyond the range of a number");
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || text.find_first_not_of(" \t", used) != std::string::npos) {
    throw ValidationError(field + " is '" + text + "', not a number");
  }
  requireFinite(field, value);
  return value;
}

Pose2D parsePose(const std::string& field, const std::string& text) {
  std::string body = text;
  body.erase(std::remove_if(body.begin(), body.end(), [](char c) { return c == '(' || c == ')'; }), body.end());
  std::vector<std::string> parts;
  std::stringstream in(body);
  for (std::string part; std::getline(in, part, ',');) parts.push_back(part);
  if (parts.size() != 3) throw ValidationError(field + " is '" + text + "', not a pose \"(x, y, yaw)\"");
  Pose2D pose;
  pose.x = parseNumber(field + " x", parts[0]);
  pose.y = parseNumber(field + " y", parts[1]);
  pose.yaw = parseNumber(field + " yaw", parts[2]);
  return pose;
}

}  // namespace xpersif::core
