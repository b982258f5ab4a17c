#include "xpersif/decision/execution.h"

#include "xpersif/component/parameters.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <thread>

#include "xpersif/GetContracts.h"
#include "xpersif/GetFeatures.h"
#include "xpersif/ResultCode.h"
#include "xpersif/component/action_wait.h"
#include "xpersif/decision/decision_common.h"
#include "xpersif/decision/planner.h"

namespace xpersif {

namespace {

const std::string kPush = "xpersif/PushAction", kGoTo = "xpersif/GoToPoseAction", kTurn = "xpersif/TurnToAction",
                  kFeatures = "xpersif/GetFeatures";

/// The value of @p parameter in @p step, or nullptr.
const std::string* valueOf(const PlanStep& step, const std::string& parameter) {
  for (std::size_t i = 0; i < step.parameters.size() && i < step.values.size(); ++i) {
    if (step.parameters[i] == parameter) return &step.values[i];
  }
  return nullptr;
}

double parseNumber(const std::string& field, const std::string& text) {
  std::size_t used = 0;
  double value = NAN;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || text.find_first_not_of(" \t", used) != std::string::npos) {
    throw core::ValidationError(field + " is '" + text + "', not a number");
  }
  core::requireFinite(field, value);
  return value;
}

/// The value of a needed parameter; throws ValidationError naming the step field when it is missing or open.
std::string need(const std::string& field, const PlanStep& step, const std::string& parameter) {
  const std::string* value = valueOf(step, parameter);
  if (!value) throw core::ValidationError(field + " has no parameter " + parameter + ", which " + step.interface_type + " needs");
  if (value->empty() || (*value)[0] == '?') {
    throw core::ValidationError(field + " leaves " + parameter + " open ('" + *value + "'); bind it before executing");
  }
  return *value;
}

PushGoal pushGoal(const std::string& field, const PlanStep& step, const std::string& pose_source) {
  PushGoal g;
  g.object = need(field, step, "?object");
  g.side = need(field, step, "?side");
  g.offset = parseNumber(field + " ?offset", need(field, step, "?offset"));
  g.distance = parseNumber(field + " ?distance", need(field, step, "?distance"));
  g.pose_source = pose_source;
  return g;
}

GoToPoseGoal goToGoal(const std::string& field, const PlanStep& step, const std::string& pose_source) {
  GoToPoseGoal g;
  g.target = parsePose(field + " ?pose", need(field, step, "?pose"));
  g.pose_source = pose_source;
  return g;
}

TurnToGoal turnGoal(const std::string& field, const PlanStep& step, const std::string& pose_source) {
  TurnToGoal g;
  g.heading = parseNumber(field + " ?heading", need(field, step, "?heading"));
  g.pose_source = pose_source;
  return g;
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

const std::vector<std::string>& executableInterfaces() {
  static const std::vector<std::string> types{kPush, kGoTo, kTurn, kFeatures};
  return types;
}

geometry_msgs::Pose2D parsePose(const std::string& field, const std::string& text) {
  std::string body = text;
  body.erase(std::remove_if(body.begin(), body.end(), [](char c) { return c == '(' || c == ')'; }), body.end());
  std::vector<std::string> parts;
  std::stringstream in(body);
  for (std::string part; std::getline(in, part, ',');) parts.push_back(part);
  if (parts.size() != 3) throw core::ValidationError(field + " is '" + text + "', not a pose \"(x, y, yaw)\"");
  geometry_msgs::Pose2D pose;
  pose.x = parseNumber(field + " x", parts[0]);
  pose.y = parseNumber(field + " y", parts[1]);
  pose.theta = parseNumber(field + " yaw", parts[2]);
  return pose;
}

std::string checkStep(const std::string& field, const PlanStep& step) {
  try {
    core::requireIdentifier(field + ".component", step.component);
    core::requireIdentifier(field + ".operator_name", step.operator_name);
    if (step.parameters.size() != step.values.size()) {
      throw core::ValidationError(field + " has " + std::to_string(step.parameters.size()) + " parameters but " +
                                  std::to_string(step.values.size()) + " values");
    }
    core::throwIfInvalid(core::checkOneOf(field + ".interface_type", step.interface_type, executableInterfaces()));
    if (step.interface_type == kPush) pushGoal(field, step, "");
    if (step.interface_type == kGoTo) goToGoal(field, step, "");
    if (step.interface_type == kTurn) turnGoal(field, step, "");
  } catch (const std::exception& e) {
    return e.what();
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
       "every step must name a component and operator, an interface type EXECUTION runs (push, go_to_pose, "
       "turn_to actions; get_features service) and a well-formed value for each parameter it needs"}};
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
  static const core::ParameterTable table(
      "execution",
      {core::numberParameter("max_age", 1.0, 0.0, 3600.0, "s: the oldest feature vector an observation step accepts"),
       core::numberParameter("fresh_timeout", 5.0, 0.0, 600.0,
                             "s to wait for a feature vector newer than the step's request"),
       core::numberParameter("server_timeout", 10.0, 0.01, 600.0,
                             "s of wall time to wait for a step's action server or service"),
       core::numberParameter("step_timeout", 300.0, 1.0, 36000.0, "s a command step may take"),
       core::intParameter("max_replans", 2, 0, 10, "replans per goal after a step fails for good"),
       core::intParameter("max_depth", 8, 1, 64, "the longest replanned plan, in steps"),
       core::namesParameter("components", {"observation", "vision", "manipulation", "relocation"}, 64,
                            "the components whose contracts are the replanning operators"),
       core::namesParameter("prefer", {"vision"}, 64, "components preferred when operators tie")});
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
  std::lock_guard<std::mutex> lock(mutex_);
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

template <class Action>
actionlib::SimpleActionClient<Action>& Execution::client(const std::string& action) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto& slot = clients_[action];
  if (!slot) {
    // Its own callback queue and spinner thread: results arrive whatever the manager's threads do.
    slot = std::make_shared<actionlib::SimpleActionClient<Action>>(nodeHandle(), action, true);
  }
  return *std::static_pointer_cast<actionlib::SimpleActionClient<Action>>(slot);
}

template <class Action, class Goal, class ResultPtr>
std::string Execution::runAction(ExecutePlan::Context& context, const std::string& action, const Goal& goal,
                                 bool& cancelled, ResultPtr* result) {
  auto& c = client<Action>(action);
  double server_timeout, step_timeout;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    server_timeout = server_timeout_;
    step_timeout = step_timeout_;
  }
  const ros::WallTime server_deadline = ros::WallTime::now() + ros::WallDuration(server_timeout);
  while (!c.isServerConnected()) {
    if (context.stopRequested()) return (cancelled = context.cancelRequested()) ? "cancelled" : "stopping";
    if (ros::WallTime::now() > server_deadline) {
      return "the action server " + nodeHandle().resolveName(action) + " did not connect within " +
             core::describeNumber(server_timeout) + " s";
    }
    c.waitForServer(ros::Duration(0.05));
  }
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
  if (state == actionlib::SimpleClientGoalState::SUCCEEDED) return "";
  const std::string text = state.getText();
  return state.toString() + (text.empty() ? "" : ": " + text);
}

std::string Execution::getFeatures(ExecutePlan::Context& context, const std::string& service,
                                   ExecutePlanResult& result) {
  double max_age, fresh_timeout, server_timeout;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    max_age = max_age_;
    fresh_timeout = fresh_timeout_;
    server_timeout = server_timeout_;
  }
  const std::string resolved = nodeHandle().resolveName(service);
  if (!ros::service::waitForService(resolved, ros::Duration(server_timeout))) {
    return "the service " + resolved + " is not available";
  }
  const ros::Time deadline = ros::Time::now() + ros::Duration(fresh_timeout);
  std::string why;
  while (true) {
    GetFeatures call;
    call.request.max_age = max_age;
    if (!ros::service::call(resolved, call)) {
      why = "the call of " + resolved + " failed";
    } else if (!call.response.success) {
      why = resolved + " refused: " + call.response.message;
    } else if (call.response.features.header.stamp <= observe_after_) {
      why = "the feature vector of " + resolved + " (stamp " +
            core::describeNumber(call.response.features.header.stamp.toSec()) +
            " s) is not newer than the plan's start or its last command's end (" +
            core::describeNumber(observe_after_.toSec()) + " s)";
    } else {
      result.observations.push_back(call.response.features);
      return "";
    }
    if (context.stopRequested() || ros::Time::now() > deadline) return why;
    // (In lockstep the clock's idle ticks bring new frames of the standing world: no physics time is asked for.)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

std::string Execution::runStep(ExecutePlan::Context& context, const PlanStep& step, ExecutePlanResult& result,
                               bool& cancelled) {
  const std::string name = step.component + "/" + step.operator_name;
  const std::string& source = context.goal().pose_source;
  try {
    if (step.interface_type == kFeatures) return getFeatures(context, name, result);
    std::string why;
    geometry_msgs::Pose2D final_pose;
    if (step.interface_type == kPush) {
      PushResultConstPtr r;
      why = runAction<PushAction>(context, name, pushGoal("step", step, source), cancelled, &r);
      if (r) final_pose = r->robot_final;
    } else if (step.interface_type == kGoTo) {
      GoToPoseResultConstPtr r;
      why = runAction<GoToPoseAction>(context, name, goToGoal("step", step, source), cancelled, &r);
      if (r) final_pose = r->final_pose;
    } else if (step.interface_type == kTurn) {
      TurnToResultConstPtr r;
      why = runAction<TurnToAction>(context, name, turnGoal("step", step, source), cancelled, &r);
      if (r) final_pose = r->final_pose;
    } else {
      return "interface type '" + step.interface_type + "' cannot be executed";
    }
    // The scene may have changed even when the command failed: later observations must be newer.
    observe_after_ = ros::Time::now();
    if (why.empty()) result.robot_poses.push_back(final_pose);
    return why;
  } catch (const std::exception& e) {
    return e.what();
  }
}

std::vector<core::Contract> Execution::readOperators(ExecutePlan::Context& context) {
  std::vector<std::string> components, prefer;
  double server_timeout;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    components = components_;
    prefer = prefer_;
    server_timeout = server_timeout_;
  }
  std::vector<ComponentContracts> loaded;
  for (const auto& component : components) {
    if (context.stopRequested()) throw core::UnavailableError("stopped while reading the contracts");
    const std::string service = nodeHandle().resolveName(component + "/get_contracts");
    GetContracts call;
    if (!ros::service::waitForService(service, ros::Duration(server_timeout)) || !ros::service::call(service, call) ||
        !call.response.success) {
      throw core::UnavailableError("the contracts of " + component + " could not be read from " + service);
    }
    ComponentContracts got{component, {}};
    for (const auto& c : call.response.contracts) got.contracts.push_back(fromContractMsg(c));
    loaded.push_back(std::move(got));
  }
  return qualifiedOperators(loaded, prefer);
}

CommandOutcome Execution::execute(ExecutePlan::Context& context, ExecutePlanResult& result) {
  const ExecutePlanGoal& goal = context.goal();
  // An observation shows the world as it is when the plan starts, or after the command before it: VISION works
  // behind the camera, so its latest vector may be older (under load, a frame from before the scene was arranged).
  observe_after_ = ros::Time::now();
  result.code = ResultCode::FAILED;
  std::vector<PlanStep> steps = goal.steps;
  int max_replans, max_depth;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    max_replans = max_replans_;
    max_depth = max_depth_;
  }
  // Replanning needs the goal, the operators (read at the first failure, so a plan that runs through costs
  // nothing) and the observed state: what held when the plan was made plus the effects of the steps that ran.
  core::PlanningProblem problem;
  problem.goal = goal.goal;
  problem.max_depth = static_cast<std::size_t>(max_depth);
  std::vector<PlanStep> succeeded;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const PlanStep& step = steps[i];
    const std::string text = stepText(step);
    std::string why;
    for (std::uint32_t attempt = 0; attempt <= goal.retries; ++attempt) {
      bool cancelled = false;
      ExecutePlanFeedback feedback;
      feedback.step = static_cast<std::uint32_t>(i);
      feedback.status = "running " + text + (attempt ? " (retry " + std::to_string(attempt) + ")" : "");
      context.publishFeedback(feedback);
      why = runStep(context, step, result, cancelled);
      if (cancelled || context.cancelRequested()) {
        result.success = false;
        result.failed_step = static_cast<std::uint32_t>(i);
        return CommandOutcome::preempted(result.message = "cancelled during step " + std::to_string(i) + " " + text);
      }
      if (context.stopRequested()) {
        result.failed_step = static_cast<std::uint32_t>(i);
        return CommandOutcome::aborted(result.message = "stopped during step " + std::to_string(i) + " " + text);
      }
      feedback.status = why.empty() ? "done " + text : "failed " + text + ": " + why;
      context.publishFeedback(feedback);
      if (why.empty()) break;
      ROS_WARN_STREAM(name() << ": step " << i << " " << text << " failed (attempt " << attempt + 1 << "): " << why);
    }
    if (why.empty()) {
      succeeded.push_back(step);
      continue;
    }
    result.success = false;
    result.failed_step = static_cast<std::uint32_t>(i);
    result.message = "step " + std::to_string(i) + " " + text + " failed after " + std::to_string(goal.retries + 1) +
                     (goal.retries ? " attempts: " : " attempt: ") + why;
    if (goal.goal.empty()) return CommandOutcome::aborted(result.message);
    if (result.replans >= static_cast<std::uint32_t>(max_replans)) {
      return CommandOutcome::aborted(result.message += "; no replan left (~max_replans " +
                                                       std::to_string(max_replans) + ")");
    }
    ++result.replans;
    core::PlanResult replanned;
    try {
      if (problem.operators.empty()) problem.operators = readOperators(context);
      // A step of a component outside ~components has no known effects: applyStep refuses it, and so do we.
      std::set<std::string> state(goal.state.begin(), goal.state.end());
      for (const auto& done : succeeded) state = core::applyStep(problem, state, toCoreStep(done));
      replanned = core::replan(problem, state, toCoreStep(step));
    } catch (const std::exception& e) {
      return CommandOutcome::aborted(result.message += "; cannot replan: " + std::string(e.what()));
    }
    if (!replanned.found) {
      return CommandOutcome::aborted(result.message += "; replanning from the observed state found no plan: " +
                                                       replanned.reason);
    }
    std::vector<PlanStep> next = toStepMessages(replanned.steps, problem.operators);
    fillOpenValues(next, steps);
    for (std::size_t k = 0; k < next.size(); ++k) {
      const std::string unfit = checkStep("replanned step " + std::to_string(k), next[k]);
      if (!unfit.empty()) return CommandOutcome::aborted(result.message += "; the new plan cannot run: " + unfit);
    }
    std::string plan_text;
    for (const auto& s : next) plan_text += (plan_text.empty() ? "" : ", ") + stepText(s);
    ROS_INFO_STREAM(name() << ": replan " << result.replans << " after " << text << ": " << plan_text);
    ExecutePlanFeedback feedback;
    feedback.step = static_cast<std::uint32_t>(i);
    feedback.status = "replanned (" + std::to_string(result.replans) + ") after " + text + ": " + plan_text;
    context.publishFeedback(feedback);
    steps = std::move(next);
    i = static_cast<std::size_t>(-1);  // the loop's ++ starts the new plan at 0
  }
  result.success = true;
  result.code = ResultCode::OK;
  result.message = std::to_string(steps.size()) + " steps done" +
                   (result.replans ? " after " + std::to_string(result.replans) + " replan(s)" : "");
  return CommandOutcome::succeeded(result.message);
}

}  // namespace xpersif
