#include "xpersif/decision/execution.h"

#include "xpersif/component/parameter_reader.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <thread>

#include "xpersif/GetContracts.h"
#include "xpersif/ResultCode.h"
#include "xpersif/component/action_wait.h"
#include "xpersif/component/lockstep_client.h"
#include "xpersif/decision/decision_common.h"
#include "xpersif/decision/planner_component.h"

namespace xpersif {

namespace {

/// The value of @p parameter in @p step, or nullptr.
const std::string* valueOf(const PlanStep& step, const std::string& parameter) {
  for (std::size_t i = 0; i < step.parameters.size() && i < step.values.size(); ++i) {
    if (step.parameters[i] == parameter) return &step.values[i];
  }
  return nullptr;
}

/// A step as the core planner names it ("component/operator", its bound values).
core::PlanStep toCoreStep(const PlanStep& step) {
  core::PlanStep out;
  out.operator_name = step.component + "/" + step.operator_name;
  out.parameters = step.parameters;
  for (std::size_t i = 0; i < step.parameters.size() && i < step.values.size(); ++i) {
    if (!step.values[i].empty() && step.values[i][0] != '?') out.bindings[step.parameters[i]] = step.values[i];
  }
  return out;
}

/// Give the new plan's open parameters the values the old plan gave the same operator's (e.g. a push's offset).
void fillOpenValues(std::vector<PlanStep>& steps, const std::vector<PlanStep>& old_steps) {
  for (auto& step : steps) {
    for (std::size_t i = 0; i < step.parameters.size() && i < step.values.size(); ++i) {
      if (step.values[i].empty() || step.values[i][0] != '?') continue;
      for (const auto& old : old_steps) {
        if (old.component != step.component || old.operator_name != step.operator_name) continue;
        const std::string* value = valueOf(old, step.parameters[i]);
        if (value && !value->empty() && (*value)[0] != '?') step.values[i] = *value;
      }
    }
  }
}

std::string stepText(const PlanStep& step) {
  std::string text = step.component + "/" + step.operator_name + "(";
  for (std::size_t i = 0; i < step.values.size(); ++i) text += (i ? ", " : "") + step.values[i];
  return text + ")";
}

}  // namespace

std::string checkStep(const std::string& field, const PlanStep& step) {
  try {
    core::requireIdentifier(field + ".component", step.component);
    core::requireIdentifier(field + ".operator_name", step.operator_name);
    core::requireMaxLength(field + ".interface_type", step.interface_type, 128);
    if (step.parameters.size() != step.values.size()) {
      throw core::ValidationError(field + " has " + std::to_string(step.parameters.size()) + " parameters but " +
                                  std::to_string(step.values.size()) + " values");
    }
    core::requireMaxSize(field + ".parameters", step.parameters.size(), core::Invocation::kMaxEntries);
    for (std::size_t i = 0; i < step.parameters.size(); ++i) {
      const std::string& parameter = step.parameters[i];
      const std::string& value = step.values[i];
      core::requireMaxLength(field + ".parameters[" + std::to_string(i) + "]", parameter, 128);
      core::requireMaxLength(field + " " + parameter, value, core::Invocation::kMaxValueLength);
      if (value.empty() || value[0] == '?') {
        throw core::ValidationError(field + " leaves " + parameter + " open ('" + value + "'); bind it before executing");
      }
    }
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

std::string checkStepContract(const std::string& field, const PlanStep& step,
                              const std::vector<core::Contract>& contracts) {
  const core::Contract* contract = nullptr;
  std::string names;
  for (const auto& c : contracts) {
    if (c.name == step.operator_name) contract = &c;
    names += (names.empty() ? "" : ", ") + c.name;
  }
  if (!contract) {
    return field + ": component " + step.component + " offers no command or operation '" + step.operator_name +
           "' (its contracts: " + (names.empty() ? "none" : names) + ")";
  }
  if (!step.interface_type.empty() && step.interface_type != contract->interface_type) {
    return field + ".interface_type is '" + step.interface_type + "', but " + step.component + "/" +
           step.operator_name + " is a " + contract->interface_type;
  }
  for (const auto& parameter : step.parameters) {
    if (std::find(contract->parameters.begin(), contract->parameters.end(), parameter) == contract->parameters.end()) {
      std::string declared;
      for (const auto& p : contract->parameters) declared += (declared.empty() ? "" : ", ") + p;
      return field + " binds " + parameter + ", which is not a parameter of " + step.component + "/" +
             step.operator_name + " (" + (declared.empty() ? "none" : declared) + ")";
    }
  }
  return "";
}

Execution::Execution(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/ExecutionNodelet") {
  core::Contract declared;
  declared.name = "execute_plan";
  declared.kind = core::Contract::Kind::Command;
  declared.interface_type = "xpersif/ExecutePlanAction";
  declared.description = "run a plan's steps through the components' commands and operations, retrying failures";
  declared.parameters = {"?steps"};
  declared.preconditions = {
      {"executable(?steps)",
       "every step must name a component and operator and bind each of its parameters to a value (no '?'); when "
       "the goal starts, each step is checked against its component's contract and binder (~invoke)"}};
  declared.effects = {"executed(?steps)"};
  ContractChecker<ExecutePlanGoal> contract(declared);
  contract
      .bind([](const ExecutePlanGoal& g) {
        std::string names;
        for (const auto& s : g.steps) names += (names.empty() ? "" : "+") + s.component + "/" + s.operator_name;
        return core::Bindings{{"?steps", names.empty() ? "none" : names}};
      })
      .check("executable(?steps)", [](const ExecutePlanGoal& g) {
        for (std::size_t i = 0; i < g.steps.size(); ++i) {
          const std::string why = checkStep("steps[" + std::to_string(i) + "]", g.steps[i]);
          if (!why.empty()) return why;
        }
        return std::string();
      });
  addCommand<ExecutePlanAction>(
      contract,
      [](const ExecutePlanGoal& g) {
        if (g.steps.empty()) throw core::ValidationError("steps is empty; a plan needs at least one step");
        core::requireMaxSize("steps", g.steps.size(), 64);
        core::requireInRange("retries", g.retries, 0, 10);
        core::requireMaxSize("goal", g.goal.size(), 64);
        core::requireMaxSize("state", g.state.size(), 256);
        for (const auto& literal : g.goal) {
          core::Literal parsed;
          try {
            parsed = core::parseLiteral(literal);
          } catch (const std::exception& e) {
            throw core::ValidationError("goal literal '" + literal + "' is malformed: " + e.what());
          }
          for (const auto& argument : parsed.arguments) {
            if (argument[0] == '?') throw core::ValidationError("goal literal '" + literal + "' has the parameter " + argument);
          }
        }
      },
      [this](ExecutePlan::Context& context, ExecutePlanResult& result) { return execute(context, result); });
}

Execution::~Execution() = default;

const core::ParameterTable& Execution::parameters() {
  static const core::ParameterTable table = [] {
    core::ParameterTable own(
      "execution",
      {core::numberParameter("max_age", 1.0, 0.0, 3600.0, "s: the oldest feature vector an observation step accepts"),
       core::numberParameter("fresh_timeout", 5.0, 0.0, 600.0,
                             "s of simulated time to wait for a feature vector newer than the step's request (lockstep: "
                             "time another participant moves the world does not count; ~step_timeout of wall time bounds it)"),
       core::numberParameter("server_timeout", 10.0, 0.01, 600.0,
                             "s of wall time to wait for a component's invoke or get_contracts"),
       core::numberParameter("step_timeout", 300.0, 1.0, 36000.0, "s a step may take"),
       core::intParameter("max_replans", 2, 0, 10, "replans per goal after a step fails for good"),
       core::intParameter("max_depth", 8, 1, 64, "the longest replanned plan, in steps"),
       core::namesParameter("components", {"observation", "vision", "manipulation", "relocation"}, 64,
                            "the components whose contracts are the replanning operators"),
       core::namesParameter("prefer", {"vision"}, 64, "components preferred when operators tie")});
    own.include(LockstepClient::parameters());
    return own;
  }();
  return table;
}

void Execution::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, Execution::parameters());
  const double max_age = parameters.get<double>("max_age");
  const double fresh_timeout = parameters.get<double>("fresh_timeout");
  const double server_timeout = parameters.get<double>("server_timeout");
  const double step_timeout = parameters.get<double>("step_timeout");
  const int max_replans = parameters.get<int>("max_replans");
  const int max_depth = parameters.get<int>("max_depth");
  const std::vector<std::string> components = parameters.get<std::vector<std::string>>("components");
  const std::vector<std::string> prefer = parameters.get<std::vector<std::string>>("prefer");
  for (const auto& c : components) core::requireIdentifier("~components entry", c);
  const bool lockstep = LockstepClient::runsInLockstep(nodeHandle(), pnh);
  std::lock_guard<std::mutex> lock(mutex_);
  lockstep_ = lockstep;
  max_age_ = max_age;
  fresh_timeout_ = fresh_timeout;
  server_timeout_ = server_timeout;
  step_timeout_ = step_timeout;
  max_replans_ = max_replans;
  max_depth_ = max_depth;
  components_ = components;
  prefer_ = prefer;
}

void Execution::onShutdown() {
  std::lock_guard<std::mutex> lock(mutex_);
  clients_.clear();
}

actionlib::SimpleActionClient<InvokeAction>& Execution::invokeClient(const std::string& component) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto& slot = clients_[component];
  // Its own callback queue and spinner thread: results arrive whatever the manager's threads do.
  if (!slot) slot = std::make_shared<actionlib::SimpleActionClient<InvokeAction>>(nodeHandle(), component + "/invoke", true);
  return *slot;
}

std::string Execution::invokeStep(ExecutePlan::Context& context, const PlanStep& step, bool check_only,
                                  bool& cancelled, std::uint8_t& code, InvokeResultConstPtr* result) {
  auto& c = invokeClient(step.component);
  const std::string action = step.component + "/invoke";
  code = ResultCode::FAILED;
  double server_timeout, step_timeout, max_age;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    server_timeout = server_timeout_;
    step_timeout = step_timeout_;
    max_age = max_age_;
  }
  const ros::WallTime server_deadline = ros::WallTime::now() + ros::WallDuration(server_timeout);
  while (!c.isServerConnected()) {
    if (context.stopRequested()) return (cancelled = context.cancelRequested()) ? "cancelled" : "stopping";
    if (ros::WallTime::now() > server_deadline) {
      code = ResultCode::UNAVAILABLE;
      return "the action server " + nodeHandle().resolveName(action) + " did not connect within " +
             core::describeNumber(server_timeout) + " s";
    }
    c.waitForServer(ros::Duration(0.05));
  }
  InvokeGoal goal;
  goal.operator_name = step.operator_name;
  goal.parameters = step.parameters;
  goal.values = step.values;
  // Offered to every interface; a binder reads those it knows (commands: pose_source; observations: max_age).
  goal.settings = {"pose_source", "max_age"};
  goal.setting_values = {context.goal().pose_source, core::describeNumber(max_age)};
  goal.check_only = check_only;
  c.sendGoal(goal);
  const ros::Time deadline = ros::Time::now() + ros::Duration(step_timeout);
  ros::WallTime last_connected = ros::WallTime::now();
  while (!waitForResultOnWallTime(c, ros::WallDuration(0.02))) {
    // A server that died (its manager killed) sends no result, and simulated time may stand still: give up
    // on it after 2 s of wall time without a connection.
    if (c.isServerConnected()) last_connected = ros::WallTime::now();
    if ((ros::WallTime::now() - last_connected).toSec() > 2.0) {
      return "the action server " + nodeHandle().resolveName(action) + " went away during the step";
    }
    if (context.stopRequested()) {
      c.cancelGoal();
      waitForResultOnWallTime(c, ros::WallDuration(10.0));
      cancelled = context.cancelRequested();
      return cancelled ? "cancelled" : "stopping";
    }
    if (ros::Time::now() > deadline) {
      c.cancelGoal();
      waitForResultOnWallTime(c, ros::WallDuration(10.0));
      return "no result within ~step_timeout " + core::describeNumber(step_timeout) + " s";
    }
  }
  const actionlib::SimpleClientGoalState state = c.getState();
  *result = c.getResult();
  if (state == actionlib::SimpleClientGoalState::SUCCEEDED) {
    code = ResultCode::OK;
    return "";
  }
  // The component's code decides (a rejected invoke goal, e.g. a busy one, carries its code too).
  if (*result && (*result)->code != ResultCode::OK) code = (*result)->code;
  const std::string text = *result && !(*result)->message.empty() ? (*result)->message : state.getText();
  return state.toString() + (text.empty() ? "" : ": " + text);
}

namespace {
/// How long an observation step waits for a feature vector newer than it needs. Outside lockstep: ~fresh_timeout
/// of simulated time (a paused clock stops the wait with the world). In lockstep, EXECUTION runs no command while it
/// observes, so simulated time that moves is another participant's (a user's controller, a test), and no frame
/// comes until the world stands: as for LOOPMODEL's scene, that wait does not count, and only ~step_timeout of wall
/// time bounds it (the sim-time deadline would pass in a fraction of a second and fail a step nobody did wrong).
class FreshWait {
 public:
  FreshWait(bool lockstep, double fresh_timeout, double step_timeout)
      : lockstep_(lockstep),
        step_timeout_(step_timeout),
        first_sim_(ros::Time::now()),
        deadline_(first_sim_ + ros::Duration(fresh_timeout)),
        give_up_(ros::WallTime::now() + ros::WallDuration(step_timeout)) {}

  bool over() const { return lockstep_ ? ros::WallTime::now() > give_up_ : ros::Time::now() > deadline_; }
  /// The cause to put before the last refusal, when it is not the step's source.
  std::string cause() const {
    const double moved = (ros::Time::now() - first_sim_).toSec();
    if (!lockstep_) return "";
    if (moved <= 0) return "no newer frame within ~step_timeout " + core::describeNumber(step_timeout_) + " s of wall time (the world stood): ";
    return "another lockstep participant kept the world moving (simulated time went on by " + core::describeNumber(moved) +
           " s within ~step_timeout " + core::describeNumber(step_timeout_) + " s of wall time), and a frame comes "
           "only when it stands: ";
  }

 private:
  bool lockstep_;
  double step_timeout_;
  ros::Time first_sim_, deadline_;
  ros::WallTime give_up_;
};
}  // namespace

std::string Execution::runStep(ExecutePlan::Context& context, const PlanStep& step, bool is_command,
                               ExecutePlanResult& result, bool& cancelled, std::uint8_t& code) {
  double fresh_timeout, step_timeout;
  bool lockstep;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    fresh_timeout = fresh_timeout_;
    step_timeout = step_timeout_;
    lockstep = lockstep_;
  }
  FreshWait wait(lockstep, fresh_timeout, step_timeout);
  while (true) {
    InvokeResultConstPtr r;
    std::string why = invokeStep(context, step, false, cancelled, code, &r);
    // The scene may have changed even when a command failed: later observations must be newer.
    if (is_command) observe_after_ = ros::Time::now();
    if (!why.empty()) {
      // An observation refused now (its source's latest vector too old: a camera coming back after its simulator
      // was restarted) is given a moment later; a command is not repeated here, nor are bad values.
      if (is_command || cancelled || code == ResultCode::INVALID || context.stopRequested()) return why;
      if (wait.over()) return wait.cause() + why;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      continue;
    }
    // An observation shows the world as it is when the plan starts, or after the command before it: VISION works
    // behind the camera, so its latest vector may be older. Such a step is repeated until it is newer.
    for (const auto& features : r->features) {
      if (features.header.stamp <= observe_after_) {
        why = "the feature vector of " + step.component + "/" + step.operator_name + " (stamp " +
              core::describeNumber(features.header.stamp.toSec()) +
              " s) is not newer than the plan's start or its last command's end (" +
              core::describeNumber(observe_after_.toSec()) + " s)";
      }
    }
    if (why.empty()) {
      result.observations.insert(result.observations.end(), r->features.begin(), r->features.end());
      for (std::size_t k = 0; k < r->outputs.size() && k < r->output_values.size(); ++k) {
        if (r->outputs[k] != "robot_pose") continue;
        const core::Pose2D pose = core::parsePose("robot_pose", r->output_values[k]);
        geometry_msgs::Pose2D msg;
        msg.x = pose.x;
        msg.y = pose.y;
        msg.theta = pose.yaw;
        result.robot_poses.push_back(msg);
      }
      return "";
    }
    if (context.stopRequested() || wait.over()) {
      code = ResultCode::FAILED;
      return (context.stopRequested() ? "" : wait.cause()) + why;
    }
    // (In lockstep the clock's idle ticks bring new frames of the standing world: no physics time is asked for.
    // A call costs a fraction of a millisecond; a longer pause would be most of an experiment's idle time.)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

std::vector<core::Contract> Execution::readContracts(ExecutePlan::Context& context, const std::string& component) {
  double server_timeout;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    server_timeout = server_timeout_;
  }
  if (context.stopRequested()) throw core::UnavailableError("stopped while reading the contracts");
  const std::string service = nodeHandle().resolveName(component + "/get_contracts");
  GetContracts call;
  // Asked again until ~server_timeout (wall time) has passed: a call that fails once on a loaded machine would
  // otherwise fail the experiment, and a failed experiment changes the rest of the campaign (seen in a study:
  // the same seed's random cell differed from experiment 45 on).
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(server_timeout);
  for (;;) {
    const double left = std::max(0.0, (until - ros::WallTime::now()).toSec());
    if (ros::service::waitForService(service, ros::Duration(left)) && ros::service::call(service, call) &&
        call.response.success) {
      break;
    }
    if (context.stopRequested() || ros::WallTime::now() >= until) {
      throw core::UnavailableError("the contracts of " + component + " could not be read from " + service +
                                   " within " + core::describeNumber(server_timeout) + " s");
    }
    ros::WallDuration(0.1).sleep();
  }
  std::vector<core::Contract> contracts;
  for (const auto& c : call.response.contracts) contracts.push_back(fromContractMsg(c));
  return contracts;
}

Execution::StepCheck Execution::checkSteps(ExecutePlan::Context& context, const std::string& label,
                                           const std::vector<PlanStep>& steps, Contracts& contracts) {
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const PlanStep& step = steps[i];
    const std::string field = label + "[" + std::to_string(i) + "]";
    std::string why = checkStep(field, step);
    if (!why.empty()) return {i, ResultCode::INVALID, why};
    if (!contracts.count(step.component)) {
      try {
        contracts[step.component] = readContracts(context, step.component);
      } catch (const std::exception& e) {
        return {i, ResultCode::UNAVAILABLE, e.what()};
      }
    }
    why = checkStepContract(field, step, contracts[step.component]);
    if (!why.empty()) return {i, ResultCode::INVALID, why};
    // The component's binder checks the values (without running anything): a bad one is found before any step runs.
    bool cancelled = false;
    std::uint8_t code = ResultCode::OK;
    InvokeResultConstPtr r;
    why = invokeStep(context, step, true, cancelled, code, &r);
    if (!why.empty()) return {i, code, field + " " + step.component + "/" + step.operator_name + ": " + why};
  }
  return {steps.size(), ResultCode::OK, ""};
}

std::vector<core::Contract> Execution::readOperators(ExecutePlan::Context& context) {
  std::vector<std::string> components, prefer;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    components = components_;
    prefer = prefer_;
  }
  std::vector<ComponentContracts> loaded;
  for (const auto& component : components) loaded.push_back({component, readContracts(context, component)});
  return qualifiedOperators(loaded, prefer);
}

/// One goal's plan as it runs (the command's thread): what it runs, what it reaches, what is known so far.
struct Execution::PlanRun {
  PlanRun(ExecutePlan::Context& context, ExecutePlanResult& result)
      : context(context), goal(context.goal()), result(result), steps(goal.steps) {}

  ExecutePlan::Context& context;
  const ExecutePlanGoal& goal;
  ExecutePlanResult& result;
  std::vector<PlanStep> steps;      ///< the plan being run (a replan replaces it)
  std::vector<PlanStep> succeeded;  ///< the steps that succeeded, across replans (their effects are observed)
  /// Replanning needs the goal, the operators (read at the first failure, so a plan that runs through costs
  /// nothing) and the observed state: what held when the plan was made plus the effects of the steps that ran.
  core::PlanningProblem problem;
  Contracts contracts;  ///< the contracts read so far, by component
  int max_replans = 0;
};

CommandOutcome Execution::execute(ExecutePlan::Context& context, ExecutePlanResult& result) {
  // An observation shows the world as it is when the plan starts, or after the command before it: VISION works
  // behind the camera, so its latest vector may be older (under load, a frame from before the scene was arranged).
  observe_after_ = ros::Time::now();
  result.replans = 0;
  result.code = ResultCode::FAILED;
  PlanRun plan(context, result);
  int max_depth;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    plan.max_replans = max_replans_;
    max_depth = max_depth_;
  }
  plan.problem.goal = plan.goal.goal;
  plan.problem.max_depth = static_cast<std::size_t>(max_depth);
  // Every step against its component's contract and binder before any runs.
  if (const StepCheck check = checkSteps(context, "steps", plan.steps, plan.contracts); !check.why.empty()) {
    return refuse(plan, check, "the plan");
  }
  for (std::size_t i = 0; i < plan.steps.size(); ++i) {
    std::string why;
    std::uint8_t code = ResultCode::OK;
    if (Ending end = attemptStep(plan, i, why, code)) return *end;
    if (why.empty()) {
      plan.succeeded.push_back(plan.steps[i]);
      continue;
    }
    if (Ending end = afterFailure(plan, i, why, code)) return *end;
    i = static_cast<std::size_t>(-1);  // the loop's ++ starts the new plan at 0
  }
  result.success = true;
  result.code = ResultCode::OK;
  result.message = std::to_string(plan.steps.size()) + " steps done" +
                   (result.replans ? " after " + std::to_string(result.replans) + " replan(s)" : "");
  return CommandOutcome::succeeded(result.message);
}

CommandOutcome Execution::refuse(PlanRun& plan, const StepCheck& check, const std::string& what) {
  plan.result.success = false;
  plan.result.failed_step = static_cast<std::uint32_t>(check.index);
  plan.result.code = check.code;
  if (plan.context.cancelRequested()) {
    return CommandOutcome::preempted(plan.result.message = "cancelled while checking " + what);
  }
  return CommandOutcome::aborted(plan.result.message = what + " cannot run: " + check.why);
}

bool Execution::isCommand(PlanRun& plan, const PlanStep& step) {
  for (const auto& c : plan.contracts[step.component]) {
    if (c.name == step.operator_name) return c.kind == core::Contract::Kind::Command;
  }
  return false;
}

Execution::Ending Execution::attemptStep(PlanRun& plan, std::size_t i, std::string& why, std::uint8_t& code) {
  const PlanStep& step = plan.steps[i];
  const std::string text = stepText(step);
  const bool is_command = isCommand(plan, step);
  ExecutePlan::Context& context = plan.context;
  for (std::uint32_t attempt = 0; attempt <= plan.goal.retries; ++attempt) {
    bool cancelled = false;
    ExecutePlanFeedback feedback;
    feedback.step = static_cast<std::uint32_t>(i);
    feedback.status = "running " + text + (attempt ? " (retry " + std::to_string(attempt) + ")" : "");
    context.publishFeedback(feedback);
    why = runStep(context, step, is_command, plan.result, cancelled, code);
    if (cancelled || context.cancelRequested()) {
      plan.result.success = false;
      plan.result.failed_step = static_cast<std::uint32_t>(i);
      return CommandOutcome::preempted(plan.result.message = "cancelled during step " + std::to_string(i) + " " + text);
    }
    if (context.stopRequested()) {
      plan.result.failed_step = static_cast<std::uint32_t>(i);
      return CommandOutcome::aborted(plan.result.message = "stopped during step " + std::to_string(i) + " " + text);
    }
    feedback.status = why.empty() ? "done " + text : "failed " + text + ": " + why;
    context.publishFeedback(feedback);
    if (why.empty()) break;
    // A bad request stays bad: no retry, no replan (decided on the component's code, not its words).
    if (code == ResultCode::INVALID) break;
    ROS_WARN_STREAM(name() << ": step " << i << " " << text << " failed (attempt " << attempt + 1 << "): " << why);
  }
  return std::nullopt;
}

Execution::Ending Execution::afterFailure(PlanRun& plan, std::size_t i, const std::string& why, std::uint8_t code) {
  ExecutePlanResult& result = plan.result;
  const std::uint32_t retries = plan.goal.retries;
  result.success = false;
  result.failed_step = static_cast<std::uint32_t>(i);
  result.message = "step " + std::to_string(i) + " " + stepText(plan.steps[i]) + " failed after " +
                   std::to_string(retries + 1) + (retries ? " attempts: " : " attempt: ") + why;
  if (code == ResultCode::INVALID) {
    result.code = ResultCode::INVALID;
    return CommandOutcome::aborted(result.message);
  }
  if (plan.goal.goal.empty()) return CommandOutcome::aborted(result.message);
  if (result.replans >= static_cast<std::uint32_t>(plan.max_replans)) {
    return CommandOutcome::aborted(result.message += "; no replan left (~max_replans " +
                                                     std::to_string(plan.max_replans) + ")");
  }
  ++result.replans;
  return replan(plan, i);
}

Execution::Ending Execution::replan(PlanRun& plan, std::size_t i) {
  ExecutePlanResult& result = plan.result;
  const PlanStep& failed = plan.steps[i];
  const std::string text = stepText(failed);
  core::PlanResult replanned;
  try {
    if (plan.problem.operators.empty()) plan.problem.operators = readOperators(plan.context);
    // A step of a component outside ~components has no known effects: applyStep refuses it, and so do we.
    std::set<std::string> state(plan.goal.state.begin(), plan.goal.state.end());
    for (const auto& done : plan.succeeded) state = core::applyStep(plan.problem, state, toCoreStep(done));
    replanned = core::replan(plan.problem, state, toCoreStep(failed));
  } catch (const std::exception& e) {
    return CommandOutcome::aborted(result.message += "; cannot replan: " + std::string(e.what()));
  }
  if (!replanned.found) {
    return CommandOutcome::aborted(result.message += "; replanning from the observed state found no plan: " +
                                                     replanned.reason);
  }
  std::vector<PlanStep> next = toStepMessages(replanned.steps, plan.problem.operators);
  fillOpenValues(next, plan.steps);
  if (const StepCheck check = checkSteps(plan.context, "replanned steps", next, plan.contracts); !check.why.empty()) {
    if (plan.context.cancelRequested()) return CommandOutcome::preempted(result.message = "cancelled while replanning");
    return CommandOutcome::aborted(result.message += "; the new plan cannot run: " + check.why);
  }
  std::string plan_text;
  for (const auto& s : next) plan_text += (plan_text.empty() ? "" : ", ") + stepText(s);
  ROS_INFO_STREAM(name() << ": replan " << result.replans << " after " << text << ": " << plan_text);
  ExecutePlanFeedback feedback;
  feedback.step = static_cast<std::uint32_t>(i);
  feedback.status = "replanned (" + std::to_string(result.replans) + ") after " + text + ": " + plan_text;
  plan.context.publishFeedback(feedback);
  plan.steps = std::move(next);
  return std::nullopt;
}

}  // namespace xpersif
