/**
 * @file robot_drive.h
 * @brief What the components that move the robot (MANIPULATION, RELOCATION) configure and hold alike: the set-up
 *        (embodiment_setup.h) with the control period and motion limits, and the robot's wheels and senses —
 *        `cmd_vel`, the robot's pose (odometry, or odometry corrected by the overhead camera) and XPERSim's lockstep
 *        clock, which their commands take part in while they run (control_ticker.h).
 */
#pragma once

#include <ros/ros.h>

#include <memory>
#include <string>

#include "xpersif/component/lockstep_client.h"
#include "xpersif/component/parameter_reader.h"
#include "xpersif/core/motion/motion.h"
#include "xpersif/embodiment/control_ticker.h"
#include "xpersif/embodiment/embodiment_setup.h"
#include "xpersif/embodiment/robot_pose_source.h"

namespace xpersif {

/// The set-up and the parameters every component that moves the robot reads: ~control_rate, ~max_linear, ~max_angular,
/// ~fix_period.
struct DriveSettings {
  EmbodimentSetup setup;
  double control_period = 0.02;
  double fix_period = 0.5;    ///< ~fix_period: lockstep, s between the overhead camera's frames a controller asks for
  core::MotionLimits limits;  ///< the defaults, with ~max_linear and ~max_angular (checked)

  /**
   * @brief Load the set-up (the arena and the robot from the world file, the objects from XPERSim's scene) and
   *        read the four parameters through @p parameters (the component's own table declares them).
   * @throws std::runtime_error or core::ValidationError with a sentence naming what is wrong
   */
  static DriveSettings read(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh,
                            const ParameterReader& parameters);
  /// ~max_linear is at most twice the wheels' top speed. @throws core::ValidationError
  void requireWithinWheels() const;
};

/// The robot's wheels and senses as a component that moves it uses them.
class RobotDrive {
 public:
  /// On configure: advertise `cmd_vel` (once), follow the robot's pose on `odom` and @p observation_topic, and
  /// make the lockstep client (an actor named after the component's private namespace); its commands' tickers ask
  /// the camera for a frame every @p fix_period s of simulated time (control_ticker.h).
  void connect(ros::NodeHandle& nh, ros::NodeHandle& private_nh, const std::string& observation_topic,
               double fix_period);
  /// On shutdown: leave the lockstep clock and stop following the pose.
  void disconnect();
  /// Send @p velocity on `cmd_vel` (nothing before connect()).
  void publishVelocity(const core::Velocity2D& velocity);
  /// The localized(robot) precondition: "" when the robot's pose is known from @p pose_source, else why not.
  std::string whyNotLocalized(const std::string& pose_source) const;
  /// The clock of a command's control loop at @p period s, sending its velocities on `cmd_vel`; with
  /// @p uses_observation it waits for @p observation_participant's frames too (connected only).
  ControlTicker ticker(double period, bool uses_observation, std::string observation_participant);

  /// The robot's pose and the objects' observation, or nullptr before connect().
  RobotPoseSource* poseSource() const { return pose_source_.get(); }

 private:
  double fix_period_ = 0;
  std::unique_ptr<RobotPoseSource> pose_source_;
  std::unique_ptr<LockstepClient> lockstep_;
  ros::Publisher cmd_vel_pub_;  // last: destroyed first
};

}  // namespace xpersif
