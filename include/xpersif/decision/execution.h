/**
 * @file execution.h
 * @brief EXECUTION: the command execute_plan, which runs a plan's steps through the components' own
 *        commands (actionlib) and operations (services), retrying a failing step.
 *
 * Steps by interface type:
 *  - xpersif/PushAction, xpersif/GoToPoseAction, xpersif/TurnToAction: a goal to the action
 *    /<ns>/<component>/<operator>, its fields from the step's values (?object, ?side, ?offset, ?distance;
 *    ?pose as "(x, y, yaw)"; ?heading), pose_source from the plan's goal;
 *  - xpersif/GetFeatures: a call of the service <component>/<operator> with max_age ~max_age (1 s). After a
 *    command, the feature vector must be newer than that command's end (the scene has changed): the call is
 *    repeated every 50 ms of wall time, for at most ~fresh_timeout seconds of ROS time, until it is.
 * A failed step is tried again up to goal.retries times. If it still fails and the goal names the literals the
 * plan reaches (`goal.goal`, with `goal.state` what held when it was planned), EXECUTION replans the rest with
 * core::replan from the observed state (goal.state plus the effects of every step that succeeded, applied as the
 * steps' contracts say), excluding the failed step, and runs the new plan; parameters the new plan leaves open
 * take the values the old plan gave the same operator. At most ~max_replans times per goal; then, or when no
 * plan is found, or without goal.goal, the goal ends ABORTED (code FAILED) with failed_step (0-based, in the plan
 * being run) and a message naming the step, the last reason and why no replan followed. The operators for
 * replanning are the contracts of ~components (read with get_contracts when a goal with goal.goal starts). A cancel cancels the running sub-goal and ends the goal
 * PREEMPTED. Feedback after each attempt: the step's index and what happened.
 * Result: observations (every get_features result, in order) and robot_poses (where each command left the
 * robot, as the command reported it).
 *
 * Everything runs in the command's own thread (blocking calls are allowed there). Action clients are kept
 * per action name, with their own callback threads.
 *
 * Parameters: Execution::parameters(), declared once with their defaults, ranges and meanings (README, Parameter
 * reference).
 */
#pragma once

#include <actionlib/client/simple_action_client.h>

#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "xpersif/ExecutePlanAction.h"
#include "xpersif/GoToPoseAction.h"
#include "xpersif/PushAction.h"
#include "xpersif/TurnToAction.h"
#include "xpersif/component/component.h"
#include "xpersif/core/planner.h"

namespace xpersif {

/// The interface types EXECUTION can run.
const std::vector<std::string>& executableInterfaces();
/// "" when @p step can be executed (a known interface type, every needed value given and well-formed), else
/// a sentence naming the step's field.
std::string checkStep(const std::string& field, const PlanStep& step);
/// "(x, y, yaw)" (also without parentheses) into a pose; throws ValidationError naming @p field otherwise.
geometry_msgs::Pose2D parsePose(const std::string& field, const std::string& text);

class Execution : public Component {
 public:
  /// Its parameters, declared once (README, Parameter reference).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  Execution(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~Execution() override;

  using ExecutePlan = CommandServer<ExecutePlanAction>;

 protected:
  void onConfigure() override;
  void onShutdown() override;

 private:
  /// One attempt of one step: "" on success, else why it failed. Sets @p cancelled when a cancel stopped it.
  std::string runStep(ExecutePlan::Context& context, const PlanStep& step, ExecutePlanResult& result,
                      bool& cancelled);
  /// Send @p goal to @p action and wait for its end; "" when it SUCCEEDED (its result in @p result).
  template <class Action, class Goal, class ResultPtr>
  std::string runAction(ExecutePlan::Context& context, const std::string& action, const Goal& goal,
                        bool& cancelled, ResultPtr* result);
  std::string getFeatures(ExecutePlan::Context& context, const std::string& service, ExecutePlanResult& result);
  CommandOutcome execute(ExecutePlan::Context& context, ExecutePlanResult& result);
  /// The qualified contracts of ~components, read with their get_contracts (in the command thread); throws
  /// UnavailableError naming a component that did not answer.
  std::vector<core::Contract> readOperators(ExecutePlan::Context& context);

  template <class Action>
  actionlib::SimpleActionClient<Action>& client(const std::string& action);

  std::mutex mutex_;
  double max_age_ = 1.0;
  double fresh_timeout_ = 5.0;
  double server_timeout_ = 10.0;
  double step_timeout_ = 300.0;
  int max_replans_ = 2;
  int max_depth_ = 8;
  std::vector<std::string> components_{"observation", "vision", "manipulation", "relocation"}, prefer_{"vision"};
  ros::Time observe_after_;  // observations must be newer: the plan's start, then its last command's end (command thread)
  std::map<std::string, std::shared_ptr<void>> clients_;  // action name -> SimpleActionClient<Action>
};

}  // namespace xpersif
