#include "xpersif/core/common/validation.h"

#include <cmath>
#include <sstream>

namespace xpersif::core {

namespace {

std::string listNames(const std::vector<std::string>& names) {
  // Long lists are cut: the sentence must stay readable in a log line.
  constexpr std::size_t kShown = 12;
  std::ostringstream out;
  for (std::size_t i = 0; i < names.size() && i < kShown; ++i) out << (i ? ", " : "") << "'" << names[i] << "'";
  if (names.size() > kShown) out << " and " << names.size() - kShown << " more";
  if (names.empty()) out << "none";
  return out.str();
}

}  // namespace

std::string describeNumber(double value) {
  if (std::isnan(value)) return "NaN";
  if (std::isinf(value)) return value > 0 ? "+inf" : "-inf";
  std::ostringstream out;
  out.precision(6);
  out << value;
  return out.str();
}

void throwIfInvalid(const std::string& message) {
  if (!message.empty()) throw ValidationError(message);
}

std::string checkFinite(const std::string& field, double value) {
  if (std::isfinite(value)) return "";
  return field + " is " + describeNumber(value) + "; it must be a finite number";
}

std::string checkAllFinite(const std::string& field, const std::vector<double>& values) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) {
      return field + "[" + std::to_string(i) + "] is " + describeNumber(values[i]) +
             "; every element must be a finite number";
    }
  }
  return "";
}

std::string checkHeading(const std::string& field, double value) {
  return checkInRange(field, value, -kMaxHeading, kMaxHeading);
}

std::string checkInRange(const std::string& field, double value, double lo, double hi) {
  std::string finite = checkFinite(field, value);
  if (!finite.empty()) return finite;
  if (value < lo || value > hi) {
    return field + " is " + describeNumber(value) + "; it must lie in [" + describeNumber(lo) + ", " +
           describeNumber(hi) + "]";
  }
  return "";
}

std::string checkPositive(const std::string& field, double value) {
  std::string finite = checkFinite(field, value);
  if (!finite.empty()) return finite;
  if (value <= 0) return field + " is " + describeNumber(value) + "; it must be greater than zero";
  return "";
}

std::string checkUnitQuaternion(const std::string& field, double x, double y, double z, double w, double tolerance) {
  const char* names[] = {"x", "y", "z", "w"};
  const double values[] = {x, y, z, w};
  for (int i = 0; i < 4; ++i) {
    std::string finite = checkFinite(field + "." + names[i], values[i]);
    if (!finite.empty()) return finite;
  }
  const double norm = std::sqrt(x * x + y * y + z * z + w * w);
  if (std::fabs(norm - 1.0) > tolerance) {
    return field + " is not a unit quaternion (its norm is " + describeNumber(norm) +
           "); normalize it, e.g. (0, 0, 0, 1) for no rotation";
  }
  return "";
}

std::string checkKnownName(const std::string& field, const std::string& name, const std::vector<std::string>& known) {
  for (const auto& k : known) {
    if (k == name) return "";
  }
  return field + " names '" + name + "', which is unknown; known names: " + listNames(known);
}

std::string checkOneOf(const std::string& field, const std::string& value, const std::vector<std::string>& allowed) {
  for (const auto& a : allowed) {
    if (a == value) return "";
  }
  return field + " is '" + value + "'; it must be one of " + listNames(allowed);
}

std::string checkMaxSize(const std::string& field, std::size_t size, std::size_t max_size) {
  if (size <= max_size) return "";
  return field + " has " + std::to_string(size) + " elements; at most " + std::to_string(max_size) + " are allowed";
}

std::string checkMaxLength(const std::string& field, const std::string& text, std::size_t max_length) {
  if (text.size() <= max_length) return "";
  return field + " is " + std::to_string(text.size()) + " bytes long; at most " + std::to_string(max_length) +
         " are allowed";
}

std::string shortenText(const std::string& text, std::size_t max_length) {
  if (text.size() <= max_length) return text;
  const auto continuation = [&](std::size_t i) { return i < text.size() && (text[i] & 0xC0) == 0x80; };
  // The number left out is at most text.size(), so a marker with that many digits is the longest it can be.
  const auto marker = [](std::size_t left_out) {
    return " [... " + std::to_string(left_out) + " bytes left out ...] ";
  };
  const std::size_t longest = marker(text.size()).size();
  if (max_length < 2 * longest) {  // no room for a marker: the beginning only
    std::size_t end = max_length;
    while (end > 0 && continuation(end)) --end;
    return text.substr(0, end);
  }
  const std::size_t room = max_length - longest;
  std::size_t head = room * 3 / 4;  // the beginning says most: what failed first
  while (head > 0 && continuation(head)) --head;
  std::size_t tail = text.size() - (room - head);
  while (continuation(tail)) ++tail;
  return text.substr(0, head) + marker(tail - head) + text.substr(tail);
}

std::string checkIdentifier(const std::string& field, const std::string& text, std::size_t max_length) {
  if (text.empty()) return field + " is empty; a name is required";
  std::string length = checkMaxLength(field, text, max_length);
  if (!length.empty()) return length;
  for (char c : text) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
                    c == '/' || c == '-';
    if (!ok) {
      return field + " '" + text + "' contains '" + std::string(1, c) +
             "'; only letters, digits, '_', '-' and '/' are allowed";
    }
  }
  return "";
}

}  // namespace xpersif::core
