/**
 * @file robot_pose_source.h
 * @brief Where the embodiment's commands get the robot's pose and the obstacles from: wheel odometry
 *        (`odom`), optionally corrected by the overhead camera (OBSERVATION's `features`), and the objects
 *        as OBSERVATION last saw them. Never the simulator's ground truth. Thread-safe.
 */
#pragma once

#include <nav_msgs/Odometry.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>

#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <geometry_msgs/Pose2D.h>

#include "xpersif/FeatureVector.h"
#include "xpersif/core/motion/motion.h"
#include "xpersif/core/common/pose_estimate.h"

namespace xpersif {

/// The objects of @p scene as obstacles, with footprints from @p footprints (unknown names are skipped).
std::vector<core::Obstacle> sceneObstacles(const FeatureVector& scene,
                                           const std::map<std::string, core::Footprint>& footprints);
/// The same for a scene as parallel names and poses (DesignExperiment's scene_objects and scene_poses).
std::vector<core::Obstacle> sceneObstacles(const std::vector<std::string>& names,
                                           const std::vector<geometry_msgs::Pose2D>& poses,
                                           const std::map<std::string, core::Footprint>& footprints);

class RobotPoseSource {
 public:
  /// Subscribes to @p odom_topic and @p observation_topic (resolved in @p nh's namespace), heard on a thread of its
  /// own: a controller waiting for its tick's odometry never waits for a worker of a busy manager.
  RobotPoseSource(ros::NodeHandle nh, const std::string& odom_topic, const std::string& observation_topic);
  ~RobotPoseSource();

  /// "" and the pose, or why there is none. @p source: "odometry" (or "") or "observation".
  std::string pose(const std::string& source, core::Pose2D* pose) const;
  /// The same for a command's `localized(robot)`: from "observation" with odometry but no camera fix yet (the
  /// simulator was just restarted or restored, so the correction was forgotten), it waits up to @p patience wall
  /// seconds for the camera's next sight of the robot rather than refuse at once.
  std::string poseForCommand(const std::string& source, core::Pose2D* pose, double patience = 2.0) const;
  /// "" when @p source is a known pose source.
  static std::string checkSource(const std::string& source);
  /// The overhead camera's latest sighting of the robot that was applied as a fix: its image's stamp and pose.
  /// Between sightings the "observation" pose runs on with odometry, which overshoots while the wheels slip.
  std::optional<std::pair<ros::Time, core::Pose2D>> lastSighting() const;
  /// Latest speeds from odometry.
  void velocity(double* linear, double* angular) const;
  bool hasOdometry() const;
  /// The latest observation, if one arrived less than @p max_age seconds (ROS time) ago (0: any age).
  std::optional<FeatureVector> observation(double max_age = 0) const;
  /// The objects of the latest observation as obstacles (footprints from @p footprints; unknown names are
  /// skipped).
  std::vector<core::Obstacle> obstacles(const std::map<std::string, core::Footprint>& footprints,
                                        double max_age = 0) const;
  /// Seconds (ROS time) since the last odometry message (infinity before the first).
  double odometryAge() const;
  /// Lockstep: wait until the odometry stamped @p stamp (and, if @p observation, an observation stamped at least
  /// @p stamp) has been taken in, so that a tick's decision never depends on which message came first. False
  /// after @p timeout wall seconds.
  bool waitFor(const ros::Time& stamp, bool observation, double timeout) const;

 private:
  /// Why the overhead camera gives no pose of the robot: no vector yet, or its latest lists the robot as not
  /// found (called with mutex_ held).
  std::string whyNotSeen() const;
  void onOdometry(const nav_msgs::Odometry::ConstPtr& odom);
  void onObservation(const FeatureVector::ConstPtr& features);
  void applyFix(const FeatureVector& features);  // mutex_ held

  mutable std::mutex mutex_;
  mutable std::condition_variable arrived_;
  ros::Time odometry_stamp_;
  std::optional<FeatureVector> pending_fix_;  // a fix newer than the odometry heard so far
  core::OdometryCorrection correction_;
  std::optional<std::pair<ros::Time, core::Pose2D>> last_sighting_;
  double linear_ = 0, angular_ = 0;
  ros::Time last_odometry_;
  FeatureVector::ConstPtr observation_;
  ros::CallbackQueue queue_;  // outlives the subscribers
  std::unique_ptr<ros::AsyncSpinner> spinner_;
  ros::Subscriber odom_sub_, observation_sub_;  // last: destroyed first
};

}  // namespace xpersif
