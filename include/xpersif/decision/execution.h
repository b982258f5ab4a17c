/**
 * @file execution.h
 * @brief EXECUTION: the command execute_plan, which runs a plan's steps through the components' own
 *        commands and operations, whatever they are, retrying a failing step and replanning around it.
 *
 * Every step goes to its component's generic command `<component>/invoke` (component.h): the step's operator,
 * parameters and values as they are, with the settings pose_source (the plan's) and max_age (~max_age) that a
 * binder may read. So any command or operation that a component offers with a contract and a binder runs; EXECUTION
 * knows no interface type. When a goal starts, before any step runs, each step is checked against the contract its
 * component gives (get_contracts: the operator exists, the interface type matches when given, each parameter is the
 * contract's) and by the component's binder (invoke with check_only): a bad value ends the goal ABORTED with code
 * INVALID, failed_step and a sentence naming the step and the parameter; nothing has moved.
 * A step whose invoke result carries feature vectors (an observation) must show the world after the plan's start
 * or its last command's end: it is repeated every 50 ms of wall time, for at most ~fresh_timeout seconds of ROS
 * time, until it does; the vectors go to the result's observations, in order. (In lockstep, simulated time that moves
 * meanwhile is another participant's and no frame comes until the world stands: that wait does not count, and
 * ~step_timeout of wall time bounds it; the sentence then names the moving world.) A step that reports robot_pose
 * adds it to robot_poses.
 * A failed step is tried again up to goal.retries times, unless its code is INVALID (then the goal ends at once,
 * code INVALID). If it still fails and the goal names the literals the plan reaches (`goal.goal`, with `goal.state`
 * what held when it was planned), EXECUTION replans the rest with core::replan from the observed state (goal.state
 * plus the effects of every step that succeeded, applied as the steps' contracts say), excluding the failed step,
 * and runs the new plan (checked as above); parameters the new plan leaves open take the values the old plan gave
 * the same operator. At most ~max_replans times per goal; then, or when no plan is found, or without goal.goal,
 * the goal ends ABORTED (code FAILED) with failed_step (0-based, in the plan being run) and a message naming the
 * step, the last reason and why no replan followed. The operators for replanning are the contracts of
 * ~components (read with get_contracts at the first failure). A cancel cancels the running invoke goal and ends
 * the goal PREEMPTED. Feedback after each attempt: the step's index and what happened.
 *
 * Everything runs in the command's own thread (blocking calls are allowed there). One invoke client per
 * component, kept, with its own callback thread.
 *
 * Parameters: Execution::parameters(), declared once with their defaults, ranges and meanings (doc/parameters.md).
 */
#pragma once

#include <actionlib/client/simple_action_client.h>

#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "xpersif/ExecutePlanAction.h"
#include "xpersif/InvokeAction.h"
#include "xpersif/component/component.h"
#include "xpersif/core/planning/planner.h"

namespace xpersif {

/// "" when @p step is well-formed (component and operator names, as many values as parameters, every value bound,
/// not open "?x", sizes within invoke's limits), else a sentence naming the step's field. Needs no component.
std::string checkStep(const std::string& field, const PlanStep& step);
/// "" when @p step fits one of its component's @p contracts (the operator exists, the interface type matches when
/// given, every parameter is the contract's), else a sentence naming the step's field.
std::string checkStepContract(const std::string& field, const PlanStep& step, const std::vector<core::Contract>& contracts);

class Execution : public Component {
 public:
  /// Its parameters, declared once (doc/parameters.md).
  static const core::ParameterTable& parameters();
  const core::ParameterTable* declaredParameters() const override { return &parameters(); }

  Execution(ros::NodeHandle nh, ros::NodeHandle private_nh);
  ~Execution() override;

  using ExecutePlan = CommandServer<ExecutePlanAction>;

 protected:
  void onConfigure() override;
  void onShutdown() override;

 private:
  using Contracts = std::map<std::string, std::vector<core::Contract>>;  // component -> its contracts
  struct StepCheck {
    std::size_t index;  ///< the first step that cannot run (the plan's size when all can)
    std::uint8_t code;  ///< xpersif/ResultCode
    std::string why;    ///< "" when every step can run
  };

  /// One attempt of one step: "" on success, else why it failed, with the component's @p code. Sets
  /// @p cancelled when a cancel stopped it.
  std::string runStep(ExecutePlan::Context& context, const PlanStep& step, bool is_command, ExecutePlanResult& result,
                      bool& cancelled, std::uint8_t& code);
  /// Send @p step to <component>/invoke and wait for its end; "" when it SUCCEEDED (its result in @p result).
  std::string invokeStep(ExecutePlan::Context& context, const PlanStep& step, bool check_only, bool& cancelled,
                         std::uint8_t& code, InvokeResultConstPtr* result);
  /// checkStep, checkStepContract (reading a component's contracts into @p contracts the first time) and the
  /// component's binder (invoke, check_only) for each of @p steps, in order; the first that fails.
  StepCheck checkSteps(ExecutePlan::Context& context, const std::string& label, const std::vector<PlanStep>& steps,
                       Contracts& contracts);
  /// The contracts @p component gives with get_contracts; throws UnavailableError when it does not answer.
  std::vector<core::Contract> readContracts(ExecutePlan::Context& context, const std::string& component);
  // ---- execute_plan as named steps over one PlanRun (execution.cpp) ----
  struct PlanRun;
  /// The goal's outcome when it ends at a step; empty: the plan goes on.
  using Ending = std::optional<CommandOutcome>;
  CommandOutcome execute(ExecutePlan::Context& context, ExecutePlanResult& result);
  /// Ends the goal before any step ran: @p what (the plan) cannot run as @p check says.
  CommandOutcome refuse(PlanRun& plan, const StepCheck& check, const std::string& what);
  /// Whether step @p step is a command of its component (its contracts are read), else an operation.
  bool isCommand(PlanRun& plan, const PlanStep& step);
  /// Step @p i, tried again up to goal.retries times unless its code is INVALID; its last @p why ("" when it
  /// succeeded) and @p code. Ends the goal when cancelled or stopped.
  Ending attemptStep(PlanRun& plan, std::size_t i, std::string& why, std::uint8_t& code);
  /// Step @p i failed for good (@p why, @p code): ends the goal unless a replan may follow, then replans.
  Ending afterFailure(PlanRun& plan, std::size_t i, const std::string& why, std::uint8_t code);
  /// A new plan from the observed state without failed step @p i, checked, in plan.steps; else ends the goal.
  Ending replan(PlanRun& plan, std::size_t i);
  /// The qualified contracts of ~components, read with their get_contracts (in the command thread); throws
  /// UnavailableError naming a component that did not answer.
  std::vector<core::Contract> readOperators(ExecutePlan::Context& context);

  actionlib::SimpleActionClient<InvokeAction>& invokeClient(const std::string& component);

  std::mutex mutex_;
  double max_age_ = 1.0;
  double fresh_timeout_ = 5.0;
  bool lockstep_ = false;  // XPERSim runs in lockstep: simulated time that moves during an observation is another's
  double server_timeout_ = 10.0;
  double step_timeout_ = 300.0;
  int max_replans_ = 2;
  int max_depth_ = 8;
  std::vector<std::string> components_{"observation", "vision", "manipulation", "relocation"}, prefer_{"vision"};
  ros::Time observe_after_;  // observations must be newer: the plan's start, then its last command's end (command thread)
  std::map<std::string, std::shared_ptr<actionlib::SimpleActionClient<InvokeAction>>> clients_;  // by component
};

}  // namespace xpersif
