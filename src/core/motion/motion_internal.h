// Helpers and tuning shared by the motion core's sources (motion_control.cpp, path_planner.cpp, push_motion.cpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "xpersif/core/motion/motion_control.h"
#include "xpersif/core/common/validation.h"

namespace xpersif::core::motion_detail {

constexpr double kPi = 3.14159265358979323846;

// Controller tuning. The gains are per second (the controller is run every 10-50 ms); the square-root
// profiles keep a decelerating command within the acceleration limits, so the robot does not overshoot.
// Gain times period stays below 1 at 50 ms. The linear and turn gains were 1.5 and 5 (floors 8 mm/s and
// 0.25 rad/s): the robot then spent a third of every approach creeping the last centimetres or finishing a
// turn, and the lockstep loop pays for every simulated second (bench/loop_speed.md).
constexpr double kLinearGain = 3.0;       // 1/s: m/s per m of remaining distance
constexpr double kMinLinear = 0.015;      // m/s: below this the last millimetres take too long
constexpr double kTurnGain = 8.0;         // 1/s: rad/s per rad of heading error
constexpr double kMinAngular = 0.4;       // rad/s
constexpr double kHeadingGain = 4.0;      // 1/s: heading correction while driving
constexpr double kStartDriving = 0.05;    // rad: heading error below which TurnToTarget gives way to Drive
constexpr double kTurnAgain = 0.6;        // rad: heading error above which Drive turns in place again
constexpr double kSteerFade = 0.03;       // m: heading correction fades out closer than this to the target

inline std::string num(double v) { return describeNumber(v); }

inline std::string point(double x, double y) {
  std::ostringstream out;
  out.precision(3);
  out << "(" << x << ", " << y << ")";
  return out.str();
}

inline double clampAbs(double v, double max) { return std::max(-max, std::min(max, v)); }

// |v| reduced so that it can reach zero within @p remaining at @p accel (with a safety factor).
inline double brakeProfile(double remaining, double accel) { return std::sqrt(2.0 * accel * std::fabs(remaining)) * 0.8; }

inline Velocity2D limitCommand(Velocity2D wanted, const Velocity2D& last, const MotionLimits& limits, double dt) {
  wanted.linear = clampAbs(wanted.linear, limits.max_linear);
  wanted.angular = clampAbs(wanted.angular, limits.max_angular);
  const double dv = limits.max_linear_acceleration * dt, dw = limits.max_angular_acceleration * dt;
  wanted.linear = std::max(last.linear - dv, std::min(last.linear + dv, wanted.linear));
  wanted.angular = std::max(last.angular - dw, std::min(last.angular + dw, wanted.angular));
  return wanted;
}

// Turn rate for a heading error: proportional, braking-limited, with a floor so that it finishes.
inline double turnRate(double error, const MotionLimits& limits) {
  double w = std::min({kTurnGain * std::fabs(error), brakeProfile(error, limits.max_angular_acceleration),
                       limits.max_angular});
  w = std::max(w, std::min(kMinAngular, limits.max_angular));
  return error >= 0 ? w : -w;
}

inline void requireUpdateInput(const Pose2D& current, double dt) {
  throwIfInvalid(checkPose("current", current));
  throwIfInvalid(checkPositive("dt", dt));
}


}  // namespace xpersif::core::motion_detail
