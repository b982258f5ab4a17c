#include "xpersif/embodiment/robot_drive.h"

#include <geometry_msgs/Twist.h>

#include "xpersif/ros/setup_loader.h"

namespace xpersif {

DriveSettings DriveSettings::read(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh,
                                  const ParameterReader& parameters) {
  DriveSettings settings;
  settings.setup = loadEmbodimentSetup(nh);
  settings.setup.takeObjectsFrom(loadSetupCatalogue(nh, private_nh));
  settings.control_period = 1.0 / parameters.get<double>("control_rate");
  settings.limits.max_linear = parameters.get<double>("max_linear");
  settings.limits.max_angular = parameters.get<double>("max_angular");
  settings.fix_period = parameters.get<double>("fix_period");
  settings.limits.require();
  return settings;
}

void DriveSettings::requireWithinWheels() const {
  core::requireInRange("~max_linear", limits.max_linear, 1e-3, 2.0 * setup.max_wheel_speed);
}

void RobotDrive::connect(ros::NodeHandle& nh, ros::NodeHandle& private_nh, const std::string& observation_topic,
                         double fix_period) {
  fix_period_ = fix_period;
  if (!cmd_vel_pub_) cmd_vel_pub_ = nh.advertise<geometry_msgs::Twist>("cmd_vel", 10);
  pose_source_ = std::make_unique<RobotPoseSource>(nh, "odom", observation_topic);
  lockstep_ = std::make_unique<LockstepClient>(nh, private_nh, private_nh.getNamespace(), false);
}

void RobotDrive::disconnect() {
  lockstep_.reset();
  pose_source_.reset();
}

void RobotDrive::publishVelocity(const core::Velocity2D& velocity) {
  geometry_msgs::Twist twist;
  twist.linear.x = velocity.linear;
  twist.angular.z = velocity.angular;
  if (cmd_vel_pub_) cmd_vel_pub_.publish(twist);
}

std::string RobotDrive::whyNotLocalized(const std::string& pose_source) const {
  core::Pose2D pose;
  return pose_source_ ? pose_source_->poseForCommand(pose_source, &pose) : "not configured";
}

ControlTicker RobotDrive::ticker(double period, bool uses_observation, std::string observation_participant) {
  return ControlTicker(lockstep_.get(), *pose_source_, period, uses_observation, std::move(observation_participant),
                       [this](const core::Velocity2D& v) { publishVelocity(v); }, fix_period_);
}

}  // namespace xpersif
