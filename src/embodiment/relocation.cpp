#include "xpersif/embodiment/relocation.h"

#include "xpersif/component/parameter_reader.h"

#include <cmath>
#include <cstdio>

#include "xpersif/ros/setup_loader.h"


namespace xpersif {

std::string describePose(double x, double y, double yaw) {
  // Millimetres for poses in an arena; a refused 1e308 or NaN shown whole (%.3f of 1e308 is 309 digits).
  auto part = [](double v) {
    if (!std::isfinite(v) || std::fabs(v) >= 1e6) return core::describeNumber(v);
    char text[32];
    std::snprintf(text, sizeof text, "%.3f", v);
    return std::string(text);
  };
  return "(" + part(x) + ", " + part(y) + ", " + part(yaw) + ")";
}

namespace {
core::Pose2D toPose(const geometry_msgs::Pose2D& p) { return {p.x, p.y, p.theta}; }
geometry_msgs::Pose2D toMsg(const core::Pose2D& p) {
  geometry_msgs::Pose2D m;
  m.x = p.x;
  m.y = p.y;
  m.theta = p.yaw;
  return m;
}

/// go_to_pose and turn_to: a pose source that exists.
template <class Goal>
void validatePoseSource(const Goal& goal) {
  core::throwIfInvalid(RobotPoseSource::checkSource(goal.pose_source));
}
}  // namespace

Relocation::Relocation(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/RelocationNodelet") {
  addCommand<GoToPoseAction>(goToPoseContract(), validatePoseSource<GoToPoseGoal>,
                             [this](auto& context, auto& result) { return goTo(context, result); },
                             {goToPoseGoalFrom, reportGoToPose});
  addCommand<TurnToAction>(turnToContract(), validatePoseSource<TurnToGoal>,
                           [this](auto& context, auto& result) { return turnTo(context, result); },
                           {turnToGoalFrom, reportTurnTo});
  addOperation<SetMaxVelocity>(setMaxVelocityContract(), [this](const auto& r) { validateMaxVelocity(r); },
                               [this](auto& r, auto& out) { setMaxVelocity(r, out); }, false, nullptr,
                               {setMaxVelocityRequestFrom, nullptr});
  addOperation<std_srvs::Trigger>(stopContract(), nullptr, [this](auto& r, auto& out) { stop(r, out); }, false, nullptr,
                                  {[](const core::Invocation&) { return std_srvs::Trigger::Request(); }, nullptr});
}

// ---- contracts ----------------------------------------------------------------------------------------------

ContractChecker<GoToPoseGoal> Relocation::goToPoseContract() {
  core::Contract go;
  go.name = "go_to_pose";
  go.kind = core::Contract::Kind::Command;
  go.interface_type = "xpersif/GoToPoseAction";
  go.description = "drive the robot to a pose, around the objects the overhead camera sees";
  go.parameters = {"?pose"};
  go.preconditions = {{"finite(?pose)", "the target must be finite numbers, its heading within +-1000 rad"},
                      {"localized(robot)", "the robot's pose must be known from the requested pose source"},
                      {"in_arena(?pose)", "the robot must fit inside the arena at the target"},
                      {"reachable(?pose)", "a collision-free path must lead from the robot to the target"}};
  // The robot is the subject (first argument): the knowledge base keeps one robot_at fact, the latest.
  go.effects = {"robot_at(robot, ?pose)"};
  ContractChecker<GoToPoseGoal> contract(go);
  contract
      .bind([](const GoToPoseGoal& g) {
        return core::Bindings{{"?pose", describePose(g.target.x, g.target.y, g.target.theta)}};
      })
      .check("finite(?pose)",
             [](const GoToPoseGoal& g) {
               // The message's own field names (geometry_msgs/Pose2D: x, y, theta), so the sentence points at them.
               std::string why = core::checkFinite("goal.target.x", g.target.x);
               if (why.empty()) why = core::checkFinite("goal.target.y", g.target.y);
               if (why.empty()) why = core::checkHeading("goal.target.theta", g.target.theta);
               return why;
             })
      .check("localized(robot)", [this](const GoToPoseGoal& g) { return drive_.whyNotLocalized(g.pose_source); })
      .check("in_arena(?pose)",
             [this](const GoToPoseGoal& g) {
               std::lock_guard<std::mutex> lock(mutex_);
               return core::checkTargetInArena(setup_.arena, g.target.x, g.target.y, setup_.robot_radius);
             })
      .check("reachable(?pose)", [this](const GoToPoseGoal& g) {
        core::PathResult path;
        return planTo(g, &path);
      });
  return contract;
}

ContractChecker<TurnToGoal> Relocation::turnToContract() {
  core::Contract turn;
  turn.name = "turn_to";
  turn.kind = core::Contract::Kind::Command;
  turn.interface_type = "xpersif/TurnToAction";
  turn.description = "turn the robot in place to a heading";
  turn.parameters = {"?heading"};
  turn.preconditions = {{"finite(?heading)", "the heading must be a finite angle within +-1000 rad"},
                        {"localized(robot)", "the robot's pose must be known from the requested pose source"}};
  turn.effects = {"robot_heading(robot, ?heading)"};
  ContractChecker<TurnToGoal> contract(turn);
  contract.bind([](const TurnToGoal& g) { return core::Bindings{{"?heading", core::describeNumber(g.heading)}}; })
      .check("finite(?heading)", [](const TurnToGoal& g) { return core::checkHeading("goal.heading", g.heading); })
      .check("localized(robot)", [this](const TurnToGoal& g) { return drive_.whyNotLocalized(g.pose_source); });
  return contract;
}

ContractChecker<SetMaxVelocity::Request> Relocation::setMaxVelocityContract() {
  core::Contract set_max;
  set_max.name = "set_max_velocity";
  set_max.kind = core::Contract::Kind::Operation;
  set_max.interface_type = "xpersif/SetMaxVelocity";
  set_max.description = "limit the speed of the robot's movements (takes effect at once, also mid-move)";
  set_max.parameters = {"?linear", "?angular"};
  set_max.effects = {"max_velocity(?linear, ?angular)"};
  ContractChecker<SetMaxVelocity::Request> contract(set_max);
  contract.bind([](const SetMaxVelocity::Request& r) {
    return core::Bindings{{"?linear", core::describeNumber(r.linear)}, {"?angular", core::describeNumber(r.angular)}};
  });
  return contract;
}

ContractChecker<std_srvs::Trigger::Request> Relocation::stopContract() {
  core::Contract stop;
  stop.name = "stop";
  stop.kind = core::Contract::Kind::Operation;
  stop.interface_type = "std_srvs/Trigger";
  stop.description = "stop the robot now: zero velocity, and the running command ends ABORTED";
  stop.effects = {"stopped(robot)"};
  return ContractChecker<std_srvs::Trigger::Request>(stop);
}

// ---- the operations' validation and handlers ----------------------------------------------------------------

void Relocation::validateMaxVelocity(const SetMaxVelocity::Request& r) const {
  core::requireInRange("linear", r.linear, 1e-3, 2.0 * setup_.max_wheel_speed);
  core::requireInRange("angular", r.angular, 1e-2, 50.0);
}

void Relocation::setMaxVelocity(const SetMaxVelocity::Request& r, SetMaxVelocity::Response& response) {
  std::lock_guard<std::mutex> lock(mutex_);
  limits_.max_linear = r.linear;
  limits_.max_angular = r.angular;
  response.linear = limits_.max_linear;
  response.angular = limits_.max_angular;
}

void Relocation::stop(const std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
  ++stop_generation_;
  drive_.publishVelocity({});
  response.message = "stopped";
}

GoToPoseGoal goToPoseGoalFrom(const core::Invocation& invocation) {
  GoToPoseGoal goal;
  const core::Pose2D pose = invocation.pose("?pose");
  goal.target.x = pose.x;
  goal.target.y = pose.y;
  goal.target.theta = pose.yaw;
  goal.pose_source = invocation.setting("pose_source", "");
  return goal;
}

TurnToGoal turnToGoalFrom(const core::Invocation& invocation) {
  TurnToGoal goal;
  goal.heading = invocation.number("?heading", -core::kMaxHeading, core::kMaxHeading);
  goal.pose_source = invocation.setting("pose_source", "");
  return goal;
}

SetMaxVelocity::Request setMaxVelocityRequestFrom(const core::Invocation& invocation) {
  SetMaxVelocity::Request request;
  request.linear = invocation.number("?linear");
  request.angular = invocation.number("?angular");
  return request;
}

void reportGoToPose(const GoToPoseResult& result, InvokeResult& out) {
  addOutput(out, "robot_pose", describePose(result.final_pose.x, result.final_pose.y, result.final_pose.theta));
}

void reportTurnTo(const TurnToResult& result, InvokeResult& out) {
  addOutput(out, "robot_pose", describePose(result.final_pose.x, result.final_pose.y, result.final_pose.theta));
}

const core::ParameterTable& Relocation::parameters() {
  static const core::ParameterTable table = [] {
    core::ParameterTable own(
        "relocation",
        {core::numberParameter("control_rate", 50.0, 1.0, 1000.0, "Hz of simulated time of the drive controller"),
         core::numberParameter("max_linear", 0.1, 1e-3, 1e3, "m/s: the fastest drive (at most twice the wheels' top speed)"),
         core::numberParameter("max_angular", 2.5, 1e-2, 50.0, "rad/s: the fastest turn"),
         core::numberParameter("position_tolerance", 0.005, 1e-4, 0.1, "m: a go_to_pose is done this close"),
         core::numberParameter("yaw_tolerance", 0.026, 1e-3, 0.5, "rad: a turn is done this close"),
         core::numberParameter("margin", 0.01, 0.0, 0.1, "m kept from walls and objects by the path planner"),
         core::numberParameter("fix_period", 0.5, 0.0, 3600.0,
                               "lockstep: s of simulated time between the overhead camera's frames the controller asks for "
                               "while it steers by them (its fixes; 0: none, only the frames of the camera's own schedule)"),
         core::numberParameter("obstacle_max_age", 5.0, 1e-6, 3600.0, "s: the oldest observation of the obstacles"),
         core::textParameter("observation_topic", "observation/features", "the overhead camera's feature vectors")});
    own.include(setupCatalogueParameters()).include(LockstepClient::parameters());
    return own;
  }();
  return table;
}

void Relocation::onConfigure() {
  const ParameterReader parameters(privateNodeHandle(), Relocation::parameters());
  const DriveSettings settings = DriveSettings::read(nodeHandle(), privateNodeHandle(), parameters);
  const double position_tolerance = parameters.get<double>("position_tolerance");
  const double yaw_tolerance = parameters.get<double>("yaw_tolerance");
  const double margin = parameters.get<double>("margin");
  const double obstacle_max_age = parameters.get<double>("obstacle_max_age");
  const std::string observation_topic = parameters.get<std::string>("observation_topic");
  settings.requireWithinWheels();

  std::lock_guard<std::mutex> lock(mutex_);
  setup_ = settings.setup;
  control_period_ = settings.control_period;
  limits_ = settings.limits;
  options_ = core::GoToPoseOptions();
  options_.position_tolerance = position_tolerance;
  options_.yaw_tolerance = yaw_tolerance;
  options_.timeout = 120.0;
  margin_ = margin;
  obstacle_max_age_ = obstacle_max_age;
  drive_.connect(nodeHandle(), privateNodeHandle(), observation_topic, settings.fix_period);
}

void Relocation::onDeactivate() { drive_.publishVelocity({}); }

void Relocation::onShutdown() {
  drive_.publishVelocity({});
  std::lock_guard<std::mutex> lock(mutex_);
  drive_.disconnect();
}

core::MotionLimits Relocation::limits() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return limits_;
}

std::string Relocation::planTo(const GoToPoseGoal& goal, core::PathResult* path) const {
  RobotPoseSource* const source = drive_.poseSource();
  if (!source) return "not configured";
  core::Pose2D start;
  std::string why = source->pose(goal.pose_source, &start);
  if (!why.empty()) return why;
  std::lock_guard<std::mutex> lock(mutex_);
  core::PathPlanner planner(setup_.arena, setup_.robot_radius, margin_);
  if (!goal.straight) {
    // The latest observation is the best knowledge of where the objects are, however old (they move only
    // when pushed); planning as if the arena were empty would drive through them.
    if (!source->observation(0)) {
      return "no overhead observation of the objects has arrived yet, so no path around them can be planned "
             "(a straight drive needs none)";
    }
    if (!source->observation(obstacle_max_age_)) {
      ROS_WARN_THROTTLE(5.0, "%s: the latest observation is older than ~obstacle_max_age (%.1f s); planning around "
                        "the objects where it saw them", name().c_str(), obstacle_max_age_);
    }
    planner.setObstacles(source->obstacles(setup_.object_footprints, 0));
  }
  *path = planner.plan(start, toPose(goal.target));
  return path->ok ? "" : path->reason;
}

template <class Context, class Controller, class Record>
CommandOutcome Relocation::drive(Context& context, const std::string& pose_source, bool sees_objects,
                                 const std::function<std::string()>& plan, Controller& controller, Record record,
                                 std::string& message) {
  const std::uint64_t stop_generation = stop_generation_;
  auto stopping = [&] { return context.stopRequested() || stop_generation_ != stop_generation; };
  ControlTicker ticker = drive_.ticker(control_period_, pose_source == "observation" || sees_objects,
                                      nodeHandle().resolveName("observation"));
  std::string why = ticker.start();
  if (!why.empty()) return CommandOutcome::aborted(message = "cannot take part in the lockstep clock: " + why);
  if (plan) {
    // Plan from the first tick's sensing, never from whatever frame came last before the join: in lockstep that
    // frame may be older than the world (issue 13).
    why = ticker.sense();
    if (why.empty()) why = plan();
    if (!why.empty()) {
      ticker.finish();
      return CommandOutcome::aborted(message = why);
    }
  }
  core::Pose2D pose;
  while (true) {
    if (stopping()) {
      ticker.finish();
      if (context.cancelRequested()) return CommandOutcome::preempted(message = "cancelled; robot stopped");
      return CommandOutcome::aborted(message = stop_generation_ != stop_generation ? "stopped by the stop operation"
                                                                                    : "component stopping; robot stopped");
    }
    why = ticker.sense();
    if (why.empty()) why = drive_.poseSource()->pose(pose_source, &pose);
    if (!why.empty()) {
      ticker.finish();
      return CommandOutcome::aborted(message = "lost the robot's pose: " + why);
    }
    controller.setLimits(limits());  // set_max_velocity takes effect mid-move
    const core::MotionFeedback fb = controller.update(pose, ticker.dt());
    record(pose, fb);
    if (fb.done || fb.failed) {
      ticker.finish();
      if (fb.failed) return CommandOutcome::aborted(message = fb.reason);
      return CommandOutcome::succeeded(message);
    }
    ticker.next(fb.command, stopping);
  }
}

CommandOutcome Relocation::goTo(GoToPose::Context& context, GoToPoseResult& result) {
  const GoToPoseGoal& goal = context.goal();
  core::PathFollower follower(limits(), options_);
  auto plan = [&]() -> std::string {
    core::PathResult path;
    const std::string why = planTo(goal, &path);
    if (!why.empty()) return "no path: " + why;
    follower.setPath(path.waypoints);
    return "";
  };
  auto record = [&](const core::Pose2D& pose, const core::MotionFeedback& fb) {
    result.final_pose = toMsg(pose);
    result.position_error = std::hypot(goal.target.x - pose.x, goal.target.y - pose.y);
    result.yaw_error = core::normalizeAngle(goal.target.theta - pose.yaw);
    if (fb.done) result.message = "reached " + describePose(pose.x, pose.y, pose.yaw);
    if (fb.done || fb.failed) return;
    GoToPoseFeedback feedback;
    feedback.pose = result.final_pose;
    feedback.phase = core::toString(fb.phase);
    feedback.distance_remaining = fb.distance_remaining;
    feedback.yaw_error = fb.yaw_error;
    context.publishFeedback(feedback);
  };
  return drive(context, goal.pose_source, !goal.straight, plan, follower, record, result.message);
}

CommandOutcome Relocation::turnTo(TurnTo::Context& context, TurnToResult& result) {
  const TurnToGoal& goal = context.goal();
  core::TurnController controller(limits(), options_.yaw_tolerance);
  controller.setGoal(goal.heading);
  auto record = [&](const core::Pose2D& pose, const core::MotionFeedback& fb) {
    result.final_pose = toMsg(pose);
    result.yaw_error = core::normalizeAngle(goal.heading - pose.yaw);
    if (fb.done) result.message = "heading " + core::describeNumber(pose.yaw);
    if (fb.done || fb.failed) return;
    TurnToFeedback feedback;
    feedback.pose = result.final_pose;
    feedback.yaw_error = fb.yaw_error;
    context.publishFeedback(feedback);
  };
  return drive(context, goal.pose_source, false, nullptr, controller, record, result.message);
}

}  // namespace xpersif
