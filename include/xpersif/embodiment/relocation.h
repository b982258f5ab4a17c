/**
 * @file relocation.h
 * @brief RELOCATION: the commands that move the robot — go to a pose (around the objects OBSERVATION
 *        sees), turn to a heading — and the operations set_max_velocity and stop.
 *
 * Closed loop at `~control_rate` Hz of ROS (simulated) time on wheel odometry, or on odometry corrected
 * by the overhead camera when a goal asks for pose_source "observation". Velocity goes out on `cmd_vel`.
 * A cancel, the stop operation or a deactivation sends a zero velocity at once (within one control
 * period) and ends the goal.
 *
 * Parameters: Relocation::parameters(), declared once with their defaults, ranges and meanings (doc/parameters.md). The arena comes from the `world` file
 * (embodiment_setup.h).
 */
#pragma once

#include <geometry_msgs/Twist.h>
#include <std_srvs/Trigger.h>

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>

#include "xpersif/GoToPoseAction.h"
#include "xpersif/SetMaxVelocity.h"
#include "xpersif/TurnToAction.h"
#include "xpersif/component/component.h"
#include "xpersif/embodiment/embodiment_setup.h"
#include "xpersif/embodiment/robot_drive.h"

namespace xpersif {

/// ~invoke's binders of RELOCATION's interfaces (they throw core::ValidationError naming the parameter):
/// go_to_pose: ?pose "(x, y, yaw)" and the setting pose_source;
GoToPoseGoal goToPoseGoalFrom(const core::Invocation& invocation);
/// turn_to: ?heading (rad, within +-core::kMaxHeading) and the setting pose_source;
TurnToGoal turnToGoalFrom(const core::Invocation& invocation);
/// set_max_velocity: ?linear, ?angular (finite; the operation checks their ranges).
SetMaxVelocity::Request setMaxVelocityRequestFrom(const core::Invocation& invocation);
/// What go_to_pose and turn_to tell ~invoke: robot_pose "(x, y, yaw)" where they left the robot.
void reportGoToPose(const GoToPoseResult& result, InvokeResult& out);
void reportTurnTo(const TurnToResult& result, InvokeResult& out);

class Relocation : public Component {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  Relocation(ros::NodeHandle nh, ros::NodeHandle private_nh);

  using GoToPose = CommandServer<GoToPoseAction>;
  using TurnTo = CommandServer<TurnToAction>;

 protected:
  void onConfigure() override;
  void onDeactivate() override;
  void onShutdown() override;

 private:
  // The contracts: preconditions checked on arrival (the set-up, the robot's pose, a path).
  ContractChecker<GoToPoseGoal> goToPoseContract();
  ContractChecker<TurnToGoal> turnToContract();
  ContractChecker<SetMaxVelocity::Request> setMaxVelocityContract();
  ContractChecker<std_srvs::Trigger::Request> stopContract();
  /// set_max_velocity: a linear speed the wheels can reach, an angular one within reason.
  void validateMaxVelocity(const SetMaxVelocity::Request& request) const;
  /// set_max_velocity: the new limits, at once (a running command takes them at its next control period).
  void setMaxVelocity(const SetMaxVelocity::Request& request, SetMaxVelocity::Response& response);
  /// stop: a zero velocity now; the running command ends ABORTED.
  void stop(const std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);

  /// The path to @p target from the current pose: "" and the plan, or why there is none.
  std::string planTo(const GoToPoseGoal& goal, core::PathResult* path) const;
  CommandOutcome goTo(GoToPose::Context& context, GoToPoseResult& result);
  /// The closed loop both commands run: @p plan (if any; "" or why not) once the first tick's sensing is in
  /// (@p sees_objects: that includes the overhead camera's frame), then every control period read the pose, let
  /// @p controller choose the velocity, send it and @p record it (result, feedback); ends on done, failure,
  /// cancel, stop or shutdown, always with a zero velocity sent. @p message gets the outcome's sentence.
  template <class Context, class Controller, class Record>
  CommandOutcome drive(Context& context, const std::string& pose_source, bool sees_objects,
                       const std::function<std::string()>& plan, Controller& controller, Record record,
                       std::string& message);
  CommandOutcome turnTo(TurnTo::Context& context, TurnToResult& result);
  core::MotionLimits limits() const;

  mutable std::mutex mutex_;
  EmbodimentSetup setup_;
  core::MotionLimits limits_;
  core::GoToPoseOptions options_;
  double control_period_ = 0.02;
  double margin_ = 0.01;
  double obstacle_max_age_ = 5.0;
  std::atomic<std::uint64_t> stop_generation_{0};  // bumped by the stop operation
  RobotDrive drive_;
};

/// "(x, y, yaw)" with a few decimals, for contract bindings and messages.
std::string describePose(double x, double y, double yaw);

}  // namespace xpersif
