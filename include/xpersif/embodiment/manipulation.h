/**
 * @file manipulation.h
 * @brief MANIPULATION: the push command — approach, contact, push, retreat — on an object that OBSERVATION
 *        sees, closed loop on the robot's pose (odometry, or odometry corrected by the overhead camera).
 *
 * The robot model (a Khepera without a gripper) has no grip or release: `~has_gripper` is false, so those
 * commands are not offered, and ROBOTMODEL reports that it holds nothing.
 *
 * Parameters: Manipulation::parameters(), declared once with their defaults, ranges and meanings (doc/parameters.md). The arena comes from the `world` file
 * (embodiment_setup.h).
 */
#pragma once

#include <geometry_msgs/Twist.h>

#include <memory>
#include <mutex>
#include <optional>

#include "xpersif/PushAction.h"
#include "xpersif/component/component.h"
#include "xpersif/embodiment/embodiment_setup.h"
#include "xpersif/embodiment/robot_drive.h"

namespace xpersif {

/// ~invoke's binder of push: ?object, ?side, ?offset, ?distance (finite numbers) and the setting pose_source;
/// throws core::ValidationError naming the parameter. The contract's preconditions check the rest on arrival.
PushGoal pushGoalFrom(const core::Invocation& invocation);
/// What push tells ~invoke: robot_pose "(x, y, yaw)" where it left the robot, blocked, pushed (m).
void reportPush(const PushResult& result, InvokeResult& out);

class Manipulation : public Component {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  Manipulation(ros::NodeHandle nh, ros::NodeHandle private_nh);

  using Push = CommandServer<PushAction>;

 protected:
  void onConfigure() override;
  void onDeactivate() override;
  void onShutdown() override;

 private:
  /// Plan the push from the current state: "" and the plan (and the approach path), or why it cannot be done.
  std::string planFor(const PushGoal& goal, core::PushPlan* plan, core::PathResult* path) const;
  /// The object as last observed: "" or why it is not known.
  std::string observedObject(const std::string& name, double max_age, core::Obstacle* object) const;
  CommandOutcome push(Push::Context& context, PushResult& result);
  /// The push controller's loop along @p plan (approach by @p path, contact, push, retreat): nothing when it is
  /// done (@p done: its last feedback), else how the command ended (stopped, cancelled, pose lost, failed).
  std::optional<CommandOutcome> runPush(Push::Context& context, ControlTicker& ticker, const core::PushPlan& plan,
                                        const core::PathResult& path, PushResult& result, core::PushFeedback* done);
  /// The camera's newest sighting of the robot (after @p last) during contact, push or retreat: the farthest
  /// along the push line in @p most.
  void noteSighting(const core::PushController& controller, ros::Time* last, double* most) const;
  /// Let the object settle, then take the first observation after that into @p result (none within the wait is
  /// no failure); nothing, or how the command ended when it was stopped while the object settled.
  std::optional<CommandOutcome> observeAfterPush(Push::Context& context, ControlTicker& ticker, PushResult& result);

  mutable std::mutex mutex_;
  EmbodimentSetup setup_;
  core::MotionLimits limits_;
  double control_period_ = 0.02;
  double margin_ = 0.01;
  double observation_max_age_ = 2.0;
  double settle_time_ = 0.3;
  double max_push_distance_ = 0.0;  ///< set by configure, from the arena
  RobotDrive drive_;
};

}  // namespace xpersif
