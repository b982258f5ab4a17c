/**
 * @file pose_estimate.h
 * @brief The robot's pose from wheel odometry, corrected by occasional external fixes (the overhead
 *        camera): the map -> odom correction that ROS localization packages publish, in a few lines.
 *
 * Odometry is smooth and fast but drifts (wheels slip while pushing); a camera fix is drift-free but late
 * (it describes the moment its image was taken). So a fix at time t is compared with the odometry at t
 * (interpolated from a short history), which gives the correction world_from_odom; the estimate is that
 * correction applied to the newest odometry. ROS-free; not thread-safe (callers lock).
 */
#pragma once

#include <deque>
#include <string>
#include <utility>

#include "xpersif/core/common/pose2d.h"

namespace xpersif::core {

/// a then b (b expressed in a's frame).
Pose2D compose(const Pose2D& a, const Pose2D& b);
Pose2D inverse(const Pose2D& a);

class OdometryCorrection {
 public:
  /// @param history_seconds how much odometry to keep for matching late fixes
  explicit OdometryCorrection(double history_seconds = 3.0);

  /// Odometry at time @p t (seconds, non-decreasing). @throws ValidationError if not finite
  void addOdometry(double t, const Pose2D& odometry);
  /**
   * @brief A fix of the robot's pose at time @p t. Returns "" when applied, or why not (no odometry around
   *        @p t: older than the history or newer than the latest odometry by more than @p max_lead seconds).
   * @throws ValidationError if not finite
   */
  std::string addFix(double t, const Pose2D& fix, double max_lead = 0.1);
  /// Forget the correction (e.g. after the robot was placed somewhere by hand) and the history.
  void reset();

  bool hasOdometry() const { return !history_.empty(); }
  bool corrected() const { return corrected_; }
  double latestTime() const { return history_.empty() ? 0.0 : history_.back().first; }
  /// Newest odometry as it came (zero pose before any).
  Pose2D odometry() const;
  /// Newest odometry with the correction applied.
  Pose2D estimate() const;
  /// world_from_odom: identity until the first fix.
  const Pose2D& correction() const { return correction_; }

 private:
  bool odometryAt(double t, double max_lead, Pose2D* pose) const;

  double history_seconds_;
  std::deque<std::pair<double, Pose2D>> history_;
  Pose2D correction_;
  bool corrected_ = false;
};

}  // namespace xpersif::core
