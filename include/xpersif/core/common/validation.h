/**
 * @file validation.h
 * @brief Input checks every command and operation uses, so that bad input gets one clear sentence
 *        and changes nothing.
 *
 * Each check comes twice, in the tf2 manner: `checkX(...)` returns the sentence ("" when the input is
 * fine) and `requireX(...)` throws ValidationError with that sentence. Field names are the caller's
 * (e.g. "goal.target_pose.position.x"), so the sentence points at the exact bad value.
 */
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

namespace xpersif::core {

/// Thrown by the require* checks; what() is a sentence meant for the person who sent the input.
class ValidationError : public std::invalid_argument {
 public:
  explicit ValidationError(const std::string& what) : std::invalid_argument(what) {}
};

/// Thrown when the work cannot be done *yet* (no learned model has arrived, a service it needs is not offered):
/// a caller may retry. At the ROS boundary it becomes ResultCode UNAVAILABLE.
class UnavailableError : public std::runtime_error {
 public:
  explicit UnavailableError(const std::string& what) : std::runtime_error(what) {}
};

/// Throw ValidationError(message) unless message is empty.
void throwIfInvalid(const std::string& message);

std::string checkFinite(const std::string& field, double value);
std::string checkAllFinite(const std::string& field, const std::vector<double>& values);
/// lo <= value <= hi (and finite).
std::string checkInRange(const std::string& field, double value, double lo, double hi);
/// The largest heading a command takes, in radians (about 159 turns): headings are normalised to (-pi, pi], and
/// far beyond a few turns a number like 1e308 is a typo whose normalisation means nothing.
constexpr double kMaxHeading = 1000.0;
/// A heading in radians: finite and within +-kMaxHeading.
std::string checkHeading(const std::string& field, double value);
/// value > 0 (and finite).
std::string checkPositive(const std::string& field, double value);
/// (x, y, z, w) finite with norm within @p tolerance of 1.
std::string checkUnitQuaternion(const std::string& field, double x, double y, double z, double w,
                                double tolerance = 1e-3);
/// @p name is one of @p known; the sentence lists what is known (up to a few names).
std::string checkKnownName(const std::string& field, const std::string& name, const std::vector<std::string>& known);
/// Same as checkKnownName, worded for enumerations ("must be one of ...").
std::string checkOneOf(const std::string& field, const std::string& value, const std::vector<std::string>& allowed);
std::string checkMaxSize(const std::string& field, std::size_t size, std::size_t max_size);
std::string checkMaxLength(const std::string& field, const std::string& text, std::size_t max_length);
/// @p text cut to at most @p max_length bytes for a store that refuses longer: its beginning (where a reason names
/// the cause) and its end kept, the middle replaced by "[... N bytes left out ...]" (N counts bytes, as the
/// store's limit does); cut between UTF-8 characters.
std::string shortenText(const std::string& text, std::size_t max_length);
/// Non-empty, at most @p max_length characters, only [A-Za-z0-9_/-] (names become ROS names and keys).
std::string checkIdentifier(const std::string& field, const std::string& text, std::size_t max_length = 128);

inline void requireFinite(const std::string& f, double v) { throwIfInvalid(checkFinite(f, v)); }
inline void requireAllFinite(const std::string& f, const std::vector<double>& v) { throwIfInvalid(checkAllFinite(f, v)); }
inline void requireInRange(const std::string& f, double v, double lo, double hi) {
  throwIfInvalid(checkInRange(f, v, lo, hi));
}
inline void requirePositive(const std::string& f, double v) { throwIfInvalid(checkPositive(f, v)); }
inline void requireUnitQuaternion(const std::string& f, double x, double y, double z, double w, double tol = 1e-3) {
  throwIfInvalid(checkUnitQuaternion(f, x, y, z, w, tol));
}
inline void requireKnownName(const std::string& f, const std::string& n, const std::vector<std::string>& known) {
  throwIfInvalid(checkKnownName(f, n, known));
}
inline void requireOneOf(const std::string& f, const std::string& v, const std::vector<std::string>& allowed) {
  throwIfInvalid(checkOneOf(f, v, allowed));
}
inline void requireMaxSize(const std::string& f, std::size_t s, std::size_t max) { throwIfInvalid(checkMaxSize(f, s, max)); }
inline void requireMaxLength(const std::string& f, const std::string& t, std::size_t max) {
  throwIfInvalid(checkMaxLength(f, t, max));
}
inline void requireIdentifier(const std::string& f, const std::string& t, std::size_t max = 128) {
  throwIfInvalid(checkIdentifier(f, t, max));
}

/// Render a double the way people read it in error messages ("NaN", "inf", "0.25").
std::string describeNumber(double value);

}  // namespace xpersif::core
