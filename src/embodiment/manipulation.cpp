#include "xpersif/embodiment/manipulation.h"

#include "xpersif/component/parameter_reader.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "xpersif/embodiment/relocation.h"  // describePose
#include "xpersif/ros/setup_loader.h"

namespace xpersif {

namespace {
geometry_msgs::Pose2D toMsg(double x, double y, double yaw) {
  geometry_msgs::Pose2D m;
  m.x = x;
  m.y = y;
  m.theta = yaw;
  return m;
}
}  // namespace

Manipulation::Manipulation(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/ManipulationNodelet") {
  core::Contract declared;
  declared.name = "push";
  declared.kind = core::Contract::Kind::Command;
  declared.interface_type = "xpersif/PushAction";
  declared.description = "push an object on one of its faces: approach, contact, push, retreat";
  declared.parameters = {"?object", "?side", "?offset", "?distance"};
  declared.preconditions = {
      {"known(?object)", "the object must be one of the set-up's objects"},
      {"valid_push(?side, ?offset, ?distance)",
       "the side must be -x, +x, -y or +y, the offset within the object's push limit (half the face's width for a "
       "box, half the radius for a cylinder or sphere), the distance positive and at most ~max_push_distance"},
      {"localized(robot)", "the robot's pose must be known from the requested pose source"},
      {"observed(scene)", "the overhead camera must have seen the object recently"},
      {"pushable(?object, ?side)", "the approach spot must be free and the object must not end in a wall"},
      {"reachable(?object, ?side)", "a collision-free path must lead from the robot to the approach spot"}};
  // The push changes the scene: what was observed before no longer holds.
  declared.effects = {"pushed(?object, ?side, ?offset, ?distance)", "not observed(scene)"};
  ContractChecker<PushGoal> contract(declared);
  contract
      .bind([](const PushGoal& g) {
        return core::Bindings{{"?object", g.object},
                              {"?side", g.side},
                              {"?offset", core::describeNumber(g.offset)},
                              {"?distance", core::describeNumber(g.distance)}};
      })
      .check("known(?object)",
             [this](const PushGoal& g) {
               std::lock_guard<std::mutex> lock(mutex_);
               return core::checkKnownName("goal.object", g.object, setup_.objectNames());
             })
      .check("valid_push(?side, ?offset, ?distance)",
             [this](const PushGoal& g) {
               std::string why = core::checkPushSide(g.side);
               if (why.empty()) why = core::checkFinite("goal.offset", g.offset);
               if (why.empty()) why = core::checkFinite("goal.distance", g.distance);
               if (!why.empty()) return why;
               std::lock_guard<std::mutex> lock(mutex_);
               const double limit = core::maxPushOffset(setup_.object_footprints.at(g.object), g.side);
               if (std::abs(g.offset) > limit) {
                 return "goal.offset is " + core::describeNumber(g.offset) + " m; on " + g.side + " of " + g.object +
                        " it must satisfy |offset| <= " + core::describeNumber(limit) + " m";
               }
               if (!(g.distance > 0) || g.distance > max_push_distance_) {
                 return "goal.distance is " + core::describeNumber(g.distance) + " m; it must be in (0, " +
                        core::describeNumber(max_push_distance_) + "] m";
               }
               return std::string();
             })
      .check("localized(robot)",
             [this](const PushGoal& g) { return drive_.whyNotLocalized(g.pose_source); })
      .check("observed(scene)",
             [this](const PushGoal& g) {
               core::Obstacle object;
               return observedObject(g.object, observation_max_age_, &object);
             })
      .check("pushable(?object, ?side)",
             [this](const PushGoal& g) {
               core::PushPlan plan;
               core::PathResult path;
               const std::string why = planFor(g, &plan, &path);
               return plan.ok ? std::string() : why;
             })
      .check("reachable(?object, ?side)", [this](const PushGoal& g) {
        core::PushPlan plan;
        core::PathResult path;
        return planFor(g, &plan, &path);
      });
  addCommand<PushAction>(
      contract, [](const PushGoal& g) {
        core::requireMaxLength("goal.object", g.object, 128);
        core::throwIfInvalid(RobotPoseSource::checkSource(g.pose_source));
      },
      [this](Push::Context& context, PushResult& result) { return push(context, result); }, {pushGoalFrom, reportPush});
}

PushGoal pushGoalFrom(const core::Invocation& invocation) {
  PushGoal goal;
  goal.object = invocation.text("?object");
  goal.side = invocation.text("?side");
  goal.offset = invocation.number("?offset");
  goal.distance = invocation.number("?distance");
  goal.pose_source = invocation.setting("pose_source", "");
  return goal;
}

void reportPush(const PushResult& result, InvokeResult& out) {
  addOutput(out, "robot_pose", describePose(result.robot_final.x, result.robot_final.y, result.robot_final.theta));
  addOutput(out, "blocked", result.blocked ? "true" : "false");
  addOutput(out, "pushed", core::describeNumber(result.pushed));
}

const core::ParameterTable& Manipulation::parameters() {
  using core::ParameterSpec;
  static const core::ParameterTable table = [] {
    core::ParameterTable own(
        "manipulation",
        {core::numberParameter("control_rate", 50.0, 1.0, 1000.0, "Hz of simulated time of the push controller"),
         core::numberParameter("max_linear", 0.1, 1e-3, 1e3, "m/s: the fastest drive (at most twice the wheels' top speed)"),
         core::numberParameter("max_angular", 2.5, 1e-2, 50.0, "rad/s: the fastest turn"),
         core::numberParameter("margin", 0.01, 0.0, 0.1, "m kept from walls and other objects when planning a push"),
         core::numberParameter("fix_period", 0.5, 0.0, 3600.0,
                               "lockstep: s of simulated time between the overhead camera's frames the controller asks for "
                               "while it steers by them (its fixes; 0: none, only the frames of the camera's own schedule)"),
         core::numberParameter("observation_max_age", 2.0, 1e-6, 3600.0,
                               "s: the oldest observation of the object a push starts from"),
         core::numberParameter("settle_time", 0.3, 0.0, 10.0, "s of simulated time the object is left to settle"),
         core::derivedParameter(ParameterSpec::Type::Double, "max_push_distance", "A / 4", 1e-6, 100.0,
                                "m: the longest push accepted"),
         core::textParameter("observation_topic", "observation/features", "the overhead camera's feature vectors"),
         core::flagParameter("has_gripper", false, "must stay false: this robot model has no gripper")});
    own.include(setupCatalogueParameters()).include(LockstepClient::parameters());
    return own;
  }();
  return table;
}

void Manipulation::onConfigure() {
  const ParameterReader parameters(privateNodeHandle(), Manipulation::parameters());
  const DriveSettings settings = DriveSettings::read(nodeHandle(), privateNodeHandle(), parameters);
  const double margin = parameters.get<double>("margin");
  const double max_age = parameters.get<double>("observation_max_age");
  const double settle = parameters.get<double>("settle_time");
  // The longest push that stays well inside the arena: pushed from the centre, an object ends halfway to the
  // nearest wall (the planner still checks every push against the walls).
  const core::ArenaGeometry& arena = settings.setup.arena;
  const double max_push_distance =
      parameters.get<double>("max_push_distance", 0.25 * std::min(arena.size_x, arena.size_y));
  const std::string observation_topic = parameters.get<std::string>("observation_topic");
  if (parameters.get<bool>("has_gripper")) {
    throw std::runtime_error("~has_gripper is true, but this robot model has no gripper to drive");
  }
  settings.requireWithinWheels();

  std::lock_guard<std::mutex> lock(mutex_);
  setup_ = settings.setup;
  control_period_ = settings.control_period;
  limits_ = settings.limits;
  margin_ = margin;
  observation_max_age_ = max_age;
  settle_time_ = settle;
  max_push_distance_ = max_push_distance;
  drive_.connect(nodeHandle(), privateNodeHandle(), observation_topic, settings.fix_period);
}

void Manipulation::onDeactivate() { drive_.publishVelocity({}); }

void Manipulation::onShutdown() {
  drive_.publishVelocity({});
  std::lock_guard<std::mutex> lock(mutex_);
  drive_.disconnect();
}

std::string Manipulation::observedObject(const std::string& name, double max_age, core::Obstacle* object) const {
  RobotPoseSource* const source = drive_.poseSource();
  if (!source) return "not configured";
  std::map<std::string, core::Footprint> footprints;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    footprints = setup_.object_footprints;
  }
  for (const auto& o : source->obstacles(footprints, max_age)) {
    if (o.name == name) {
      *object = o;
      return "";
    }
  }
  return source->observation(max_age) ? "the overhead camera does not see " + name + " now"
                                      : "no observation in the last " + core::describeNumber(max_age) + " s";
}

std::string Manipulation::planFor(const PushGoal& goal, core::PushPlan* plan, core::PathResult* path) const {
  core::Obstacle object;
  std::string why = observedObject(goal.object, observation_max_age_, &object);
  if (!why.empty()) return why;
  core::Pose2D start;
  why = drive_.poseSource()->pose(goal.pose_source, &start);
  if (!why.empty()) return why;
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<core::Obstacle> others;
  for (const auto& o : drive_.poseSource()->obstacles(setup_.object_footprints, observation_max_age_)) {
    if (o.name != goal.object) others.push_back(o);
  }
  core::PushRequest request;
  request.object = goal.object;
  request.side = goal.side;
  request.offset = goal.offset;
  request.distance = goal.distance;
  core::PushOptions options;
  options.margin = margin_;
  options.max_distance = max_push_distance_;
  *plan = core::planPush(object, request, setup_.robot_radius, setup_.arena, others, options);
  if (!plan->ok) return plan->reason;
  // The approach path keeps clear of every object, the pushed one included.
  core::PathPlanner planner(setup_.arena, setup_.robot_radius, margin_);
  others.push_back(object);
  planner.setObstacles(others);
  *path = planner.plan(start, plan->approach);
  return path->ok ? "" : "no path to the approach spot " +
                             describePose(plan->approach.x, plan->approach.y, plan->approach.yaw) + ": " + path->reason;
}

CommandOutcome Manipulation::push(Push::Context& context, PushResult& result) {
  const PushGoal& goal = context.goal();
  // The overhead camera's view after the push is part of the result: the clock waits for its frames.
  ControlTicker ticker = drive_.ticker(control_period_, true, nodeHandle().resolveName("observation"));
  std::string why = ticker.start();
  if (!why.empty()) return CommandOutcome::aborted(result.message = "cannot take part in the lockstep clock: " + why);
  // Plan from the first tick's sensing, never from whatever frame came last before the join: in lockstep that
  // frame may be older than the world (issue 13).
  why = ticker.sense();
  core::PushPlan plan;
  core::PathResult path;
  if (why.empty()) why = planFor(goal, &plan, &path);
  if (!why.empty()) {
    ticker.finish();
    return CommandOutcome::aborted(result.message = why);
  }
  core::Obstacle before;
  observedObject(goal.object, observation_max_age_, &before);
  result.object_before = toMsg(before.x, before.y, before.yaw);
  const ros::Time started = ros::Time::now();

  core::PushFeedback done;
  if (auto ended = runPush(context, ticker, plan, path, result, &done)) return *ended;
  if (auto ended = observeAfterPush(context, ticker, result)) return *ended;
  ticker.finish();
  result.blocked = done.blocked;
  result.pushed = done.pushed;
  result.message = "pushed " + goal.object + " on " + goal.side + " by " + core::describeNumber(goal.distance) +
                   " m in " + core::describeNumber((ros::Time::now() - started).toSec()) + " s" +
                   (done.blocked ? " (it resisted: the robot stalled after " + core::describeNumber(done.pushed) +
                                       " m and backed off)"
                                 : "") +
                   (result.observed_after ? "" : " (not seen afterwards)");
  return CommandOutcome::succeeded(result.message);
}

std::optional<CommandOutcome> Manipulation::runPush(Push::Context& context, ControlTicker& ticker,
                                                    const core::PushPlan& plan, const core::PathResult& path,
                                                    PushResult& result, core::PushFeedback* done) {
  const PushGoal& goal = context.goal();
  auto stopping = [&] { return context.stopRequested(); };
  core::MotionLimits limits;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    limits = limits_;
  }
  core::PushController controller(limits);
  controller.start(plan, path.waypoints);
  core::Pose2D pose;
  // Steering by the overhead camera, the pose between its sightings runs on with odometry, which goes on
  // counting while the wheels slip against an object that resists: how far a blocked push got is what the
  // camera saw, not that overshoot (a late frame under load made it 14 mm against a cube that never moved).
  const bool by_camera = goal.pose_source == "observation";
  double sighted_most = -std::numeric_limits<double>::infinity();
  ros::Time sighted_last;
  while (true) {
    if (context.stopRequested()) {
      controller.stop();
      ticker.finish();
      if (context.cancelRequested()) return CommandOutcome::preempted(result.message = "cancelled; robot stopped");
      return CommandOutcome::aborted(result.message = "component stopping; robot stopped");
    }
    std::string why = ticker.sense();
    if (why.empty()) why = drive_.poseSource()->pose(goal.pose_source, &pose);
    if (!why.empty()) {
      ticker.finish();
      return CommandOutcome::aborted(result.message = "lost the robot's pose: " + why);
    }
    if (by_camera) noteSighting(controller, &sighted_last, &sighted_most);
    core::PushFeedback fb = controller.update(pose, ticker.dt());
    result.robot_final = toMsg(pose.x, pose.y, pose.yaw);
    if (fb.failed) {
      ticker.finish();
      return CommandOutcome::aborted(result.message = "push failed: " + fb.reason);
    }
    if (fb.done) {
      if (fb.blocked && std::isfinite(sighted_most)) fb.pushed = std::clamp(sighted_most, 0.0, fb.pushed);
      *done = fb;
      return std::nullopt;
    }
    PushFeedback feedback;
    feedback.phase = core::toString(fb.phase);
    feedback.progress = fb.progress;
    feedback.pose = result.robot_final;
    context.publishFeedback(feedback);
    ticker.next(fb.command, stopping);
  }
}

void Manipulation::noteSighting(const core::PushController& controller, ros::Time* last, double* most) const {
  const auto phase = controller.phase();
  if (phase != core::PushPhase::Contact && phase != core::PushPhase::Push && phase != core::PushPhase::Retreat) return;
  const auto seen = drive_.poseSource()->lastSighting();
  if (!seen || seen->first <= *last) return;
  *last = seen->first;
  *most = std::max(*most, core::pastContact(controller.plan(), seen->second));
}

std::optional<CommandOutcome> Manipulation::observeAfterPush(Push::Context& context, ControlTicker& ticker,
                                                             PushResult& result) {
  const PushGoal& goal = context.goal();
  auto stopping = [&] { return context.stopRequested(); };
  // Let the object come to rest (the robot standing still), then take the first observation made after that.
  const ros::Time settled = ticker.now() + ros::Duration(settle_time_);
  ticker.requestObservation(settled);  // in lockstep the camera renders when asked
  while (ticker.now() < settled) {
    if (!ticker.next({}, stopping) || !ticker.sense().empty()) {
      ticker.finish();
      return CommandOutcome::aborted(result.message = "stopped while waiting for the object to settle");
    }
  }
  const ros::Time deadline = settled + ros::Duration(std::max(1.0, 3 * observation_max_age_));
  while (ticker.now() < deadline) {
    const auto seen = drive_.poseSource()->observation();
    // In lockstep, the camera's next frame (frames follow the physics' own time, stamps include idle time).
    if (seen && (ticker.lockstep() ? ticker.freshObservation() : seen->header.stamp >= settled)) {
      for (const auto& o : seen->objects) {
        if (o.name != goal.object) continue;
        result.object_after = toMsg(o.position.x, o.position.y, o.yaw);
        result.observed_after = true;
      }
      break;
    }
    ticker.requestObservation();
    if (!ticker.next({}, stopping) || !ticker.sense().empty()) break;
  }
  return std::nullopt;
}

}  // namespace xpersif
