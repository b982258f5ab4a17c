#include "xpersif/xpersim/xpersim.h"

#include "xpersif/component/parameter_reader.h"

#include <geometry_msgs/Twist.h>
#include <nav_msgs/Odometry.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/JointState.h>
#include <std_srvs/Trigger.h>
#include <tf2_msgs/TFMessage.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <chrono>
#include <set>

#include "xpersif/BodyPoses.h"
#include "xpersif/GetScene.h"
#include "xpersif/InjectFault.h"
#include "xpersif/IrRanges.h"
#include "xpersif/Scene.h"
#include "xpersif/SetPose.h"
#include <unistd.h>

#include "xpersif/Lockstep.h"
#include "xpersif/LockstepTick.h"
#include "xpersif/Step.h"
#include "xpersif/WheelSpeeds.h"
#include "xpersif/WorldState.h"
#include "xpersif/component/message_checks.h"
#include "xpersif/ros/conversions.h"

namespace xpersif {

namespace {

constexpr std::int64_t kMaxStepsPerCall = 100000;
constexpr std::size_t kMaxWorldStateBytes = 4u << 20;  ///< a world state is a few kB per body

core::Contract operation(const std::string& name, const std::string& type, const std::string& description,
                         std::vector<std::string> effects = {}) {
  core::Contract c;
  c.name = name;
  c.interface_type = type;
  c.description = description;
  c.effects = std::move(effects);
  return c;
}

geometry_msgs::Twist toTwist(const Eigen::Vector3d& linear, const Eigen::Vector3d& angular) {
  geometry_msgs::Twist t;
  t.linear.x = linear.x();
  t.linear.y = linear.y();
  t.linear.z = linear.z();
  t.angular.x = angular.x();
  t.angular.y = angular.y();
  t.angular.z = angular.z();
  return t;
}

const char* toString(XPerSim::ClockMode mode) {
  switch (mode) {
    case XPerSim::ClockMode::RealTime: return "realtime";
    case XPerSim::ClockMode::Fast: return "fast";
    case XPerSim::ClockMode::Lockstep: return "lockstep";
  }
  return "?";
}

// ---- what each operation refuses before anything changes --------------------------------------------------

/// step: 1..kMaxStepsPerCall physics steps.
void validateStep(const Step::Request& request) {
  if (request.steps < 1 || request.steps > kMaxStepsPerCall) {
    throw core::ValidationError("steps is " + std::to_string(request.steps) + "; it must lie in 1.." +
                                std::to_string(kMaxStepsPerCall));
  }
}

/// lockstep: a participant's name and a role that exists.
void validateLockstep(const Lockstep::Request& request) {
  core::requireIdentifier("participant", request.participant, 128);
  if (request.role > Lockstep::Request::ACTOR) {
    throw core::ValidationError("role is " + std::to_string(request.role) + "; it must be SENSOR (0) or ACTOR (1)");
  }
}

/// checkpoint: no state given (it gives one).
void validateCheckpoint(const WorldState::Request& request) {
  if (!request.state.empty()) {
    throw core::ValidationError("state must be empty: ~checkpoint takes a state, ~restore gives one");
  }
  core::requireInRange("min_clock", request.min_clock, 0.0, 1e9);  // not used here, but never anything
}

/// restore: a state, not larger than a world state can be.
void validateRestore(const WorldState::Request& request) {
  if (request.state.empty()) throw core::ValidationError("state is empty: give a state that ~checkpoint gave");
  core::requireInRange("min_clock", request.min_clock, 0.0, 1e9);
  core::requireMaxLength("state", request.state, kMaxWorldStateBytes);
}

}  // namespace

XPerSim::XPerSim(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Component(std::move(nh), std::move(private_nh), "xpersif/XPerSimNodelet") {
  allow_fault_injection_ = ParameterReader(privateNodeHandle(), parameters()).get<bool>("allow_fault_injection");
  declareOperations();
}

XPerSim::~XPerSim() { stopThread(); }

void XPerSim::declareOperations() {
  using Trigger = std_srvs::Trigger;
  using TriggerContract = ContractChecker<Trigger::Request>;
  addOperation<Trigger>(
      TriggerContract(operation("pause", "std_srvs/Trigger", "stop advancing simulated time", {"paused(sim)"})), nullptr,
      [this](auto& r, auto& out) { pause(r, out); });
  addOperation<Trigger>(
      TriggerContract(operation("resume", "std_srvs/Trigger", "advance simulated time again", {"not paused(sim)"})),
      nullptr, [this](auto& r, auto& out) { resume(r, out); });
  addOperation<Step>(
      ContractChecker<Step::Request>(
          operation("step", "xpersif/Step", "pause, then advance a number of physics steps", {"paused(sim)"})),
      validateStep, [this](auto& r, auto& out) { step(r, out); });
  addOperation<Lockstep>(lockstepContract(), validateLockstep,
                         [this](auto& r, auto& out) { joinOrLeaveLockstep(r, out); }, false);
  addOperation<Trigger>(
      TriggerContract(operation("reset", "std_srvs/Trigger", "put the world back to its initial state", {"reset(sim)"})),
      nullptr, [this](auto& r, auto& out) { reset(r, out); });
  // A run that may be resumed takes a checkpoint at every experiment boundary; a resumed run restores one.
  addOperation<WorldState>(
      standingContract(operation("checkpoint", "xpersif/WorldState",
                                 "the world's whole state, from which it goes on exactly as a restored world would")),
      validateCheckpoint, [this](auto& r, auto& out) { checkpoint(r, out); });
  addOperation<WorldState>(
      standingContract(operation("restore", "xpersif/WorldState", "put the world back in a state ~checkpoint gave")),
      validateRestore, [this](auto& r, auto& out) { restore(r, out); });
  addOperation<SetPose>(setPoseContract(), [this](const SetPose::Request& r) { validateSetPose(r); },
                        [this](auto& r, auto& out) { setPose(r, out); });
  addOperation<GetScene>(
      ContractChecker<GetScene::Request>(
          operation("get_scene", "xpersif/GetScene", "the scene description clients render from")),
      nullptr, [this](auto& r, auto& out) { getScene(r, out); }, false);
  if (allow_fault_injection_) {
    addOperation<InjectFault>(
        ContractChecker<InjectFault::Request>(
            operation("inject_fault", "xpersif/InjectFault", "test hook: a non-finite or huge force on a body")),
        [this](const InjectFault::Request& r) { validateInjectFault(r); },
        [this](auto& r, auto& out) { injectFault(r, out); });
  }
}

// ---- contracts ----------------------------------------------------------------------------------------------

ContractChecker<Lockstep::Request> XPerSim::lockstepContract() {
  core::Contract lockstep = operation("lockstep", "xpersif/Lockstep", "join or leave the lockstep clock",
                                      {"participant(?name)"});
  lockstep.parameters = {"?name"};
  lockstep.preconditions = {{"lockstep(sim)", "the clock mode is lockstep"}};
  ContractChecker<Lockstep::Request> contract(lockstep);
  contract.bind([](const Lockstep::Request& r) { return core::Bindings{{"?name", r.participant}}; })
      .check("lockstep(sim)", [this](const Lockstep::Request&) -> std::string {
        std::lock_guard<std::mutex> lock(world_mutex_);
        return lockstep_ ? "" : "the simulator runs in " + std::string(toString(mode_)) + " mode, not lockstep";
      });
  return contract;
}

ContractChecker<WorldState::Request> XPerSim::standingContract(core::Contract contract) {
  // Checked when the call arrives, and again under the world's lock when it is carried out.
  contract.preconditions = {{"standing(sim)", "no command is moving the world"}};
  ContractChecker<WorldState::Request> checker(contract);
  checker.check("standing(sim)", [this](const WorldState::Request&) {
    std::lock_guard<std::mutex> lock(world_mutex_);
    return whyWorldMovesLocked();
  });
  return checker;
}

ContractChecker<SetPose::Request> XPerSim::setPoseContract() {
  core::Contract set_pose = operation("set_pose", "xpersif/SetPose", "place the robot or an object",
                                      {"at(?name, ?pose)"});
  set_pose.parameters = {"?name", "?pose"};
  set_pose.preconditions = {{"clear(?name)", "the body's new place overlaps no other body"}};
  ContractChecker<SetPose::Request> contract(set_pose);
  contract
      .bind([](const SetPose::Request& r) {
        return core::Bindings{{"?name", r.name},
                              {"?pose", core::describeNumber(r.pose.position.x) + "_" + core::describeNumber(r.pose.position.y)}};
      })
      .check("clear(?name)", [this](const SetPose::Request& request) -> std::string {
        std::lock_guard<std::mutex> lock(world_mutex_);
        const auto check = world_->checkPlacement(request.name, fromPoseMsg(request.pose), request.on_floor);
        return check.problem == core::PhysicsWorld::PlacementCheck::Problem::Overlap ? check.why : "";
      });
  return contract;
}

std::string XPerSim::whyWorldMovesLocked() const {
  return lockstep_ && lockstep_->wantsTime() ? "a command is moving the world (a lockstep participant wants time)" : "";
}

void XPerSim::requireStandingWorldLocked() const {
  const std::string why = whyWorldMovesLocked();
  if (!why.empty()) throw core::UnavailableError(why + ": take or restore a world state between commands");
}

void XPerSim::validateSetPose(const SetPose::Request& request) {
  core::requireMaxLength("name", request.name, 128);
  core::throwIfInvalid(checkPose("pose", request.pose));
  std::lock_guard<std::mutex> lock(world_mutex_);
  core::requireKnownName("name", request.name, world_->spec().bodyNames());
  // Inside the arena, not under the floor (whatever else is there): malformed for this world.
  const auto check = world_->checkPlacement(request.name, fromPoseMsg(request.pose), request.on_floor);
  if (check.problem == core::PhysicsWorld::PlacementCheck::Problem::Invalid) throw core::ValidationError(check.why);
}

void XPerSim::validateInjectFault(const InjectFault::Request& request) {
  std::lock_guard<std::mutex> lock(world_mutex_);
  core::requireKnownName("name", request.name, world_->spec().bodyNames());
}

// ---- handlers -----------------------------------------------------------------------------------------------

void XPerSim::pause(const std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
  paused_ = true;
  response.message = "paused";
}

void XPerSim::resume(const std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
  // In lockstep mode a resumed clock goes on ticking as its participants ask.
  restart_pacing_ = true;
  {
    std::lock_guard<std::mutex> lock(world_mutex_);
    halted_.clear();  // tried again by hand: a blow-up that persists halts it again, with its sentence
  }
  paused_ = false;
  wake_.notify_all();
  lockstep_wake_.notify_all();
  response.message = "running";
}

void XPerSim::step(const Step::Request& request, Step::Response& response) {
  std::unique_lock<std::mutex> lock(world_mutex_);
  if (lockstep_ && running_ && !lockstep_->participants().empty()) {
    // Whole ticks, through the participants: time passes for everyone, in step.
    if (paused_) {
      throw core::UnavailableError(
          "the simulator is paused, and in lockstep with participants time passes only through their ticks: "
          "resume it first" + (halted_.empty() ? std::string() : " (" + halted_ + ")"));
    }
    const std::uint64_t ticks = (request.steps + steps_per_tick_ - 1) / steps_per_tick_;
    const std::uint64_t until = ticks_done_ + lockstep_->requestedTicks() + ticks;
    lockstep_->requestTicks(ticks);
    lockstep_wake_.notify_all();
    while (ticks_done_ < until && running_ && ros::ok() && !paused_) {
      lockstep_wake_.wait_for(lock, std::chrono::milliseconds(100));
    }
    response.time = simTimeLocked();
    return;
  }
  paused_ = true;
  for (std::int64_t i = 0; i < request.steps && halted_.empty(); ++i) stepLocked();
  response.time = simTimeLocked();
}

void XPerSim::joinOrLeaveLockstep(const Lockstep::Request& request, Lockstep::Response& response) {
  std::lock_guard<std::mutex> lock(world_mutex_);
  if (request.join) {
    lockstep_->join(request.participant, request.role == Lockstep::Request::SENSOR
                                             ? core::LockstepCoordinator::Role::Sensor
                                             : core::LockstepCoordinator::Role::Actor);
  } else {
    if (lockstep_->leave(request.participant)) world_->setVelocity(0, 0);  // its controller is gone
  }
  response.clock = lockstep_clock_;
  response.tick = lockstep_->tick();
  response.phase = lockstep_->phase() == core::LockstepCoordinator::Phase::Sense ? LockstepTick::SENSE
                                                                                  : LockstepTick::ACT;
  response.stamp = ros::Time(simTimeLocked());
  response.complete = lockstep_->phaseComplete();
  response.message = request.participant + (request.join ? " joined" : " left") + " at tick " +
                     std::to_string(response.tick);
  traceLocked(response.message);
  lockstep_wake_.notify_all();
}

void XPerSim::reset(const std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
  std::lock_guard<std::mutex> lock(world_mutex_);
  world_->reset();
  newLineageLocked();
  unhaltLocked();
  idle_time_ = 0;
  next_frame_ = next_sensors_ = 0;
  restart_pacing_ = true;
  publishFrameLocked();
  publishSensorsLocked();
  response.message = "reset to t=0";
}

void XPerSim::checkpoint(const WorldState::Request&, WorldState::Response& response) {
  std::lock_guard<std::mutex> lock(world_mutex_);
  requireStandingWorldLocked();
  response.state = world_->checkpoint();
  response.physics_time = world_->time();
  response.clock = simTimeLocked();
  response.lineage = lineage_;
  restoredLocked("checkpoint");
  response.message = "checkpoint at t=" + core::describeNumber(world_->time()) + " s of physics";
}

void XPerSim::restore(const WorldState::Request& request, WorldState::Response& response) {
  std::lock_guard<std::mutex> lock(world_mutex_);
  requireStandingWorldLocked();
  const double clock = std::max(simTimeLocked(), request.min_clock);
  world_->restoreState(request.state);  // a state of another world is refused with a sentence, nothing changed
  // Simulated time never runs backwards in one simulator: the clock stays, the idle time makes up the difference.
  idle_time_ = std::max(0.0, clock - world_->time());
  response.physics_time = world_->time();
  response.clock = simTimeLocked();
  response.lineage = lineage_;
  restoredLocked("restore");
  response.message = "restored the world at t=" + core::describeNumber(world_->time()) + " s of physics";
}

void XPerSim::setPose(const SetPose::Request& request, SetPose::Response& response) {
  std::lock_guard<std::mutex> lock(world_mutex_);
  world_->setPose(request.name, fromPoseMsg(request.pose), request.on_floor);  // checks again
  traceLocked("set_pose " + request.name);
  unhaltLocked();
  publishFrameLocked();
  publishSensorsLocked();
  response.message = request.name + " placed";
}

void XPerSim::getScene(const GetScene::Request&, GetScene::Response& response) {
  std::lock_guard<std::mutex> lock(world_mutex_);
  if (!world_) throw std::runtime_error("no world yet: configure the simulator first");
  response.scene = toSceneMsg(world_->scene());
}

void XPerSim::injectFault(const InjectFault::Request& request, InjectFault::Response&) {
  std::lock_guard<std::mutex> lock(world_mutex_);
  world_->injectFault(request.name, request.explode);
}

void XPerSim::unhaltLocked() {
  if (halted_.empty()) return;
  halted_.clear();
  paused_ = false;
  wake_.notify_all();
  lockstep_wake_.notify_all();
}

const core::ParameterTable& XPerSim::parameters() {
  using core::ParameterSpec;
  static const core::ParameterTable table(
      "xpersim",
      {core::textParameter("world", "", "path of the world file (doc/worlds.md); required"),
       core::textParameter("clock_mode", "realtime",
                           "how simulated time advances: at ~real_time_factor × wall time, as fast as possible, or "
                           "one control tick at a time when every participant is done (doc/lockstep.md)",
                           {"realtime", "fast", "lockstep"}),
       core::numberParameter("real_time_factor", 1.0, 0.01, 100.0, "realtime mode: simulated seconds per wall second"),
       core::numberParameter("tf_rate", 1000.0, 1.0, 10000.0, "Hz of simulated time for /tf and /clock (realtime, fast)"),
       core::numberParameter("sensor_rate", 50.0, 0.1, 1000.0, "Hz of simulated time for odom, ir and joint_states"),
       core::numberParameter("max_frame_rate", 1000.0, 1.0, 100000.0,
                             "fast mode: at most this many /tf + /clock frames per wall second"),
       core::flagParameter("start_paused", false, "start with the physics paused (~resume starts it)"),
       core::numberParameter("tick_period", 0.02, 1e-4, 1.0,
                             "lockstep: s of simulated time per control tick (rounded to whole physics steps)"),
       core::numberParameter("participant_timeout", 10.0, 0.01, 3600.0,
                             "lockstep: s of wall time a participant may owe a report before it is dropped"),
       core::numberParameter("idle_period", 0.02, 1e-3, 10.0,
                             "lockstep: s of wall time without anyone wanting time before an idle tick (clock on, "
                             "physics still)"),
       core::textParameter("trace_file", "", "debug: append every stepped tick's command and poses to this file"),
       core::derivedParameter(ParameterSpec::Type::Int, "seed", "the world file's physics.seed", 0, 2147483647,
                              "the run's seed for what the simulator draws at random (frictions redrawn per push)"),
       core::flagParameter("allow_fault_injection", false, "test hook: offer ~inject_fault")});
  return table;
}

/// What ~configure reads, every value checked before anything changes.
struct XPerSim::Settings {
  std::string world_file, mode, trace_file;
  double real_time_factor = 1.0, tf_rate = 1000.0, sensor_rate = 50.0, max_frame_rate = 1000.0;
  bool start_paused = false;
  double tick_period = 0.02, participant_timeout = 10.0, idle_period = 0.02;
  bool has_seed = false;
  int seed = -1;
};

XPerSim::Settings XPerSim::readSettings() {
  const ParameterReader parameters(privateNodeHandle(), XPerSim::parameters());
  if (!parameters.has("world")) throw std::runtime_error("~world is not set; give the path of a world file");
  Settings s;
  s.world_file = parameters.get<std::string>("world");
  s.mode = parameters.get<std::string>("clock_mode");
  s.real_time_factor = parameters.get<double>("real_time_factor");
  s.tf_rate = parameters.get<double>("tf_rate");
  s.sensor_rate = parameters.get<double>("sensor_rate");
  s.max_frame_rate = parameters.get<double>("max_frame_rate");
  s.start_paused = parameters.get<bool>("start_paused");
  s.tick_period = parameters.get<double>("tick_period");
  s.participant_timeout = parameters.get<double>("participant_timeout");
  s.idle_period = parameters.get<double>("idle_period");
  s.trace_file = parameters.get<std::string>("trace_file");
  // The run's seed, for what the simulator draws at random (objects' frictions redrawn per contact episode);
  // without it, the world file's physics.seed.
  s.has_seed = parameters.has("seed");
  s.seed = parameters.get<int>("seed", -1);
  return s;
}

void XPerSim::onConfigure() {
  const Settings settings = readSettings();
  // Built completely before it replaces anything: a bad world file leaves the old world running.
  auto world = std::make_unique<core::PhysicsWorld>(core::loadWorldFile(settings.world_file));
  if (settings.has_seed) world->setRedrawSeed(static_cast<std::uint64_t>(settings.seed));

  stopThread();
  std::lock_guard<std::mutex> lock(world_mutex_);
  world_ = std::move(world);
  newLineageLocked();
  applySettingsLocked(settings);
  openTraceLocked(settings);
  if (!clock_pub_) connect();
  publishDescriptionLocked();
  publishFrameLocked();
  publishSensorsLocked();
}

void XPerSim::applySettingsLocked(const Settings& settings) {
  mode_ = settings.mode == "fast"       ? ClockMode::Fast
          : settings.mode == "lockstep" ? ClockMode::Lockstep
                                        : ClockMode::RealTime;
  real_time_factor_ = settings.real_time_factor;
  tf_period_ = 1.0 / settings.tf_rate;
  sensor_period_ = 1.0 / settings.sensor_rate;
  min_frame_wall_interval_ = 1.0 / settings.max_frame_rate;
  next_frame_ = next_sensors_ = 0;
  paused_ = settings.start_paused;
  // Lockstep: whole physics steps per control tick; participants join again after a reconfigure.
  steps_per_tick_ = std::max(1, static_cast<int>(std::lround(settings.tick_period / world_->spec().physics.step)));
  tick_period_ = steps_per_tick_ * world_->spec().physics.step;
  idle_period_ = settings.idle_period;
  idle_time_ = 0;
  lockstep_.reset(mode_ == ClockMode::Lockstep ? new core::LockstepCoordinator(settings.participant_timeout) : nullptr);
  timing_ = {};
  // Wall nanoseconds, kept increasing: a participant that hears a larger id knows it was forgotten and joins again.
  lockstep_clock_ = std::max(lockstep_clock_ + 1, static_cast<std::uint64_t>(ros::WallTime::now().toNSec()));
}

void XPerSim::openTraceLocked(const Settings& settings) {
  trace_.reset();
  if (settings.trace_file.empty()) return;
  trace_ = std::make_unique<std::ofstream>(settings.trace_file, std::ios::app);
  if (!*trace_) throw std::runtime_error("~trace_file: cannot write '" + settings.trace_file + "'");
  traceLocked("configure world=" + settings.world_file + " mode=" + settings.mode);
}

void XPerSim::connect() {
  ros::NodeHandle& nh = nodeHandle();
  ros::NodeHandle& pnh = privateNodeHandle();
  // Latched: a node that starts while a lockstep clock stands still still learns what time it is.
  clock_pub_ = nh.advertise<rosgraph_msgs::Clock>("/clock", 10, true);
  tf_pub_ = nh.advertise<tf2_msgs::TFMessage>("/tf", 100);
  tf_static_pub_ = nh.advertise<tf2_msgs::TFMessage>("/tf_static", 1, true);
  scene_pub_ = pnh.advertise<Scene>("scene", 1, true);
  markers_pub_ = pnh.advertise<visualization_msgs::MarkerArray>("markers", 1, true);
  ground_truth_pub_ = pnh.advertise<BodyPoses>("ground_truth", 10);
  odom_pub_ = nh.advertise<nav_msgs::Odometry>("odom", 10);
  ir_pub_ = nh.advertise<IrRanges>("ir", 10);
  joints_pub_ = nh.advertise<sensor_msgs::JointState>("joint_states", 10);
  tick_pub_ = pnh.advertise<LockstepTick>("tick", 10);
  ros::NodeHandle report_nh(pnh);
  report_nh.setCallbackQueue(&report_queue_);
  lockstep_done_sub_ = report_nh.subscribe<LockstepDone>("lockstep_done", 100, &XPerSim::onLockstepDone, this,
                                                         ros::TransportHints().tcpNoDelay());
  if (!report_spinner_) {
    report_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &report_queue_);
    report_spinner_->start();
  }
  const auto hints = ros::TransportHints().tcpNoDelay();
  cmd_vel_sub_ = nh.subscribe<geometry_msgs::Twist>("cmd_vel", 10, &XPerSim::onCmdVel, this, hints);
  wheel_speeds_sub_ = nh.subscribe<WheelSpeeds>("wheel_speeds", 10, &XPerSim::onWheelSpeeds, this, hints);
}

void XPerSim::onCmdVel(const geometry_msgs::Twist::ConstPtr& twist) {
  std::string why = checkVector3("cmd_vel.linear", twist->linear);
  if (why.empty()) why = checkVector3("cmd_vel.angular", twist->angular);
  if (why.empty()) {
    std::lock_guard<std::mutex> lock(world_mutex_);
    if (world_) world_->setVelocity(twist->linear.x, twist->angular.z);
    char line[96];
    std::snprintf(line, sizeof line, "cmd_vel v=%a w=%a", twist->linear.x, twist->angular.z);
    traceLocked(line);
    return;
  }
  ROS_ERROR_STREAM_THROTTLE(1.0, name() << ": ignored " << why << "; the last command stays");
  events().publish(events().make(ComponentEvent::OPERATION, "cmd_vel", "refused", why));
}

void XPerSim::onWheelSpeeds(const WheelSpeeds::ConstPtr& speeds) {
  try {
    std::lock_guard<std::mutex> lock(world_mutex_);
    if (world_) world_->setWheelSpeeds(speeds->left, speeds->right);
    traceLocked("wheel_speeds");
  } catch (const core::ValidationError& e) {
    ROS_ERROR_STREAM_THROTTLE(1.0, name() << ": ignored " << e.what() << "; the last command stays");
    events().publish(events().make(ComponentEvent::OPERATION, "wheel_speeds", "refused", e.what()));
  }
}

void XPerSim::publishDescriptionLocked() {
  const core::SceneDescription& scene = world_->scene();
  Scene scene_msg = toSceneMsg(scene);
  scene_msg.header.stamp = ros::Time(simTimeLocked());
  scene_pub_.publish(scene_msg);

  tf2_msgs::TFMessage fixed;
  visualization_msgs::MarkerArray markers;
  std::set<std::string> robot_links;
  for (const auto& link : world_->spec().robot.links) robot_links.insert(link.name);
  int id = 0;
  for (const auto& node : scene.nodes) {
    if (!node.dynamic) {
      geometry_msgs::TransformStamped t;
      t.header.frame_id = node.parent;
      t.child_frame_id = node.name;
      t.transform = toTransformMsg(node.parent_from_node);
      fixed.transforms.push_back(t);
    }
    if (robot_links.count(node.name)) continue;  // the robot is drawn from robot_description
    for (const auto& v : node.visuals) {
      visualization_msgs::Marker m;
      m.header.frame_id = node.name;
      m.ns = node.name;
      m.id = id++;
      m.frame_locked = true;  // rviz moves it with its tf frame: only tf flows per frame
      m.action = visualization_msgs::Marker::ADD;
      m.pose = toPoseMsg(v.offset);
      m.color.r = v.color.r;
      m.color.g = v.color.g;
      m.color.b = v.color.b;
      m.color.a = v.color.a;
      switch (v.shape.type) {
        case core::Shape::Type::Box:
          m.type = visualization_msgs::Marker::CUBE;
          m.scale.x = v.shape.box_size.x();
          m.scale.y = v.shape.box_size.y();
          m.scale.z = v.shape.box_size.z();
          break;
        case core::Shape::Type::Cylinder:
          m.type = visualization_msgs::Marker::CYLINDER;
          m.scale.x = m.scale.y = 2 * v.shape.radius;
          m.scale.z = v.shape.length;
          break;
        case core::Shape::Type::Sphere:
          m.type = visualization_msgs::Marker::SPHERE;
          m.scale.x = m.scale.y = m.scale.z = 2 * v.shape.radius;
          break;
      }
      markers.markers.push_back(m);
    }
  }
  tf_static_pub_.publish(fixed);
  markers_pub_.publish(markers);
  ros::param::set("robot_description", world_->spec().robot.urdf);
}

void XPerSim::publishFrameLocked() {
  const ros::Time stamp(simTimeLocked());
  rosgraph_msgs::Clock clock;
  clock.clock = stamp;
  clock_pub_.publish(clock);
  // A frame published between two ticks (set_pose, paused or in lockstep) would repeat the last frame's stamp,
  // and tf2 drops repeated data: viewers would keep showing the old pose. One nanosecond later, it is kept.
  ros::Time tf_stamp = stamp;
  // (A clock set back on purpose, a reset, moves by more than a millisecond and is taken as it is.)
  if (tf_stamp <= last_tf_stamp_ && (last_tf_stamp_ - tf_stamp).toSec() < 1e-3) tf_stamp = last_tf_stamp_ + ros::Duration(0, 1);
  last_tf_stamp_ = tf_stamp;
  auto frame_message = boost::make_shared<tf2_msgs::TFMessage>();
  tf2_msgs::TFMessage& frame = *frame_message;
  const core::FrameTransforms transforms = world_->dynamicTransforms();
  frame.transforms.reserve(transforms.size());
  for (const auto& node : world_->scene().nodes) {
    if (!node.dynamic) continue;
    geometry_msgs::TransformStamped t;
    t.header.stamp = tf_stamp;
    t.header.frame_id = node.parent;
    t.child_frame_id = node.name;
    t.transform = toTransformMsg(transforms.at(node.name));
    frame.transforms.push_back(t);
  }
  tf_pub_.publish(frame_message);
}

void XPerSim::publishSensorsLocked() {
  const ros::Time stamp(simTimeLocked());
  const core::WorldSpec& spec = world_->spec();

  BodyPoses truth;
  truth.header.stamp = stamp;
  truth.header.frame_id = world_->scene().world_frame;
  for (const auto& body : spec.bodyNames()) {
    truth.names.push_back(body);
    truth.poses.push_back(toPoseMsg(world_->bodyPose(body)));
    truth.velocities.push_back(toTwist(world_->bodyLinearVelocity(body), world_->bodyAngularVelocity(body)));
  }
  ground_truth_pub_.publish(truth);

  const auto odometry = world_->odometry();
  auto odom_message = boost::make_shared<nav_msgs::Odometry>();
  nav_msgs::Odometry& odom = *odom_message;
  odom.header.stamp = stamp;
  odom.header.frame_id = "odom";
  odom.child_frame_id = spec.robot.links[0].name;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(odometry.x, odometry.y, 0);
  pose.linear() = Eigen::AngleAxisd(odometry.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  odom.pose.pose = toPoseMsg(pose);
  odom.twist.twist.linear.x = odometry.linear;
  odom.twist.twist.angular.z = odometry.angular;
  odom_pub_.publish(odom_message);

  IrRanges ir;
  ir.header.stamp = stamp;
  ir.frames = spec.robot.ir_sensors;
  ir.max_range = static_cast<float>(spec.robot.ir_range);
  for (double r : world_->irRanges()) ir.ranges.push_back(static_cast<float>(r));
  ir_pub_.publish(ir);

  const auto wheels = world_->wheels();
  sensor_msgs::JointState joints;
  joints.header.stamp = stamp;
  joints.name = {spec.robot.left_wheel_joint, spec.robot.right_wheel_joint};
  joints.position = {wheels.left_angle, wheels.right_angle};
  joints.velocity = {wheels.left_rate, wheels.right_rate};
  joints_pub_.publish(joints);
}

bool XPerSim::physicsStepLocked() {
  const core::PhysicsWorld::StepResult result = world_->step();
  if (result.ok) return true;
  ++blow_ups_;
  last_problem_ = result.problem;
  last_problem_wall_ = ros::WallTime::now().toSec();
  ROS_ERROR_STREAM_THROTTLE(1.0, name() << ": " << result.problem);
  if (result.halted) {
    // Not resolvable by putting bodies at rest: pause with the reason rather than fail the same step forever.
    halted_ = result.problem + "; the simulator is paused until set_pose moves a body or reset";
    paused_ = true;
    events().publish(events().make(ComponentEvent::OPERATION, "physics", "paused", halted_));
    return false;
  }
  events().publish(events().make(ComponentEvent::OPERATION, "physics", "recovered", result.problem));
  return true;  // resolved: the step was taken
}

void XPerSim::stepLocked() {
  if (!physicsStepLocked()) return;
  const double t = simTimeLocked() + 1e-9;
  // In fast mode frames are also limited per wall second: viewers cannot use 30k frames/s, and the
  // messages would cost more than the physics (bench/README.md).
  bool frame_allowed = true;
  if (mode_ == ClockMode::Fast && !paused_) {
    const double now = ros::WallTime::now().toSec();
    frame_allowed = now - last_frame_wall_ >= min_frame_wall_interval_;
    if (frame_allowed && t >= next_frame_) last_frame_wall_ = now;
  }
  if (t >= next_frame_ && frame_allowed) {
    publishFrameLocked();
    next_frame_ += tf_period_;
    if (next_frame_ < t) next_frame_ = t + tf_period_;
  }
  if (t >= next_sensors_) {
    publishSensorsLocked();
    next_sensors_ += sensor_period_;
    if (next_sensors_ < t) next_sensors_ = t + sensor_period_;
  }
}

void XPerSim::onActivate() {
  running_ = true;
  restart_pacing_ = true;
  thread_ = std::thread([this] { loop(); });
}

void XPerSim::onDeactivate() { stopThread(); }

void XPerSim::onShutdown() { stopThread(); }

void XPerSim::stopThread() {
  running_ = false;
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void XPerSim::newLineageLocked() {
  // This process and this moment: a restarted simulator, or a world built again, is never taken for the old one.
  lineage_ = std::to_string(::getpid()) + "." + std::to_string(ros::WallTime::now().toNSec());
}

void XPerSim::restoredLocked(const std::string& what) {
  ++epoch_;  // sensors start their frame schedules again, as fresh ones after a restart do
  if (lockstep_) lockstep_->restartSchedules();
  unhaltLocked();
  next_frame_ = next_sensors_ = simTimeLocked();
  restart_pacing_ = true;
  traceLocked(what);
  publishFrameLocked();
  publishSensorsLocked();
}

void XPerSim::publishTickLocked(std::uint8_t phase, const std::vector<std::string>& fresh) {
  auto message = boost::make_shared<LockstepTick>();  // shared: a participant in this process gets it uncopied
  LockstepTick& tick = *message;
  tick.clock = lockstep_clock_;
  tick.tick = lockstep_->tick();
  tick.phase = phase;
  tick.stamp = ros::Time(simTimeLocked());
  tick.idle = last_tick_idle_;
  tick.physics_time = world_->time();
  tick.fresh = fresh;
  if (phase == LockstepTick::SENSE) tick.requested = lockstep_->requested();
  tick.participants = lockstep_->participants();
  tick.epoch = epoch_;
  tick_pub_.publish(message);
}

void XPerSim::traceLocked(const std::string& event) {
  if (!trace_ || !world_) return;
  char head[64];
  std::snprintf(head, sizeof head, "step %llu t=%a ", static_cast<unsigned long long>(world_->stepCount()), world_->time());
  *trace_ << head << event << '\n';
  for (const auto& [body, pose] : world_->dynamicTransforms()) {
    const Eigen::Quaterniond q(pose.rotation());
    char line[256];
    std::snprintf(line, sizeof line, "  %s %a %a %a %a %a %a %a", body.c_str(), pose.translation().x(),
                  pose.translation().y(), pose.translation().z(), q.w(), q.x(), q.y(), q.z());
    *trace_ << line << '\n';
  }
  trace_->flush();
}

void XPerSim::onLockstepDone(const LockstepDone::ConstPtr& done) {
  std::lock_guard<std::mutex> lock(world_mutex_);
  if (!lockstep_) return;
  std::string why = checkVector3("cmd_vel.linear", done->cmd_vel.linear);
  if (why.empty()) why = checkVector3("cmd_vel.angular", done->cmd_vel.angular);
  if (why.empty()) {
    core::LockstepCoordinator::Command command{done->drives != 0, done->cmd_vel.linear.x, done->cmd_vel.angular.z,
                                               done->wants_frames};
    why = lockstep_->report(done->participant, done->tick,
                            done->phase == LockstepTick::SENSE ? core::LockstepCoordinator::Phase::Sense
                                                               : core::LockstepCoordinator::Phase::Act,
                            done->wants_time, done->published, command, done->next_due);
  }
  if (!why.empty()) ROS_WARN_STREAM_THROTTLE(1.0, name() << ": lockstep report ignored: " << why);
  lockstep_wake_.notify_all();
}

void XPerSim::dropLateLocked(double now) {
  for (const auto& late : lockstep_->dropLate(now)) {
    last_problem_ = "lockstep participant '" + late + "' did not report tick " + std::to_string(lockstep_->tick()) +
                    " within " + core::describeNumber(lockstep_->timeout()) + " s; it was dropped and time goes on";
    last_problem_wall_ = now;
    traceLocked("dropped " + late);
    ROS_WARN_STREAM(name() << ": " << last_problem_);
    events().publish(events().make(ComponentEvent::OPERATION, "lockstep", "dropped", last_problem_));
  }
}

void XPerSim::advanceTickLocked(double now) {
  // Nobody wants time: an idle tick keeps the software's timers going (actionlib's status, ROS timers) but
  // the world stands still, so how long the loop thinks never changes what the physics does.
  const bool idle = !lockstep_->wantsTime();
  const auto step_began = std::chrono::steady_clock::now();
  const core::LockstepCoordinator::Command& command = lockstep_->command();
  if (command.drives) world_->setVelocity(command.linear, command.angular);
  lockstep_->consumeRequest();
  if (idle) {
    idle_time_ += tick_period_;
    ++idle_ticks_;
  } else {
    for (int i = 0; i < steps_per_tick_; ++i) {
      if (!physicsStepLocked()) break;  // halted: the world waits, paused, with the reason
    }
    if (trace_) {
      char line[160];
      std::snprintf(line, sizeof line, "tick %llu drives=%d v=%a w=%a", static_cast<unsigned long long>(lockstep_->tick()),
                    command.drives ? 1 : 0, command.linear, command.angular);
      std::string participants;
      for (const auto& p : lockstep_->participants()) participants += " " + p;
      traceLocked(line + participants);
    }
  }
  last_tick_wall_ = now;
  last_tick_idle_ = idle;
  const auto publish_began = std::chrono::steady_clock::now();
  publishFrameLocked();
  publishSensorsLocked();
  lockstep_->startTick(lockstep_->tick() + 1, now, world_->time(), idle);
  ++ticks_done_;
  publishTickLocked(LockstepTick::SENSE, {});
  sense_began_ = std::chrono::steady_clock::now();
  sense_owed_ = !lockstep_->phaseComplete();
  if (!idle) {
    using Seconds = std::chrono::duration<double>;
    timing_.addStep(Seconds(step_began - act_began_).count(), Seconds(publish_began - step_began).count(),
                    Seconds(sense_began_ - publish_began).count());
  }
  lockstep_wake_.notify_all();  // the step operation waits for its ticks
}

void XPerSim::lockstepLoop() {
  using Phase = core::LockstepCoordinator::Phase;
  std::unique_lock<std::mutex> lock(world_mutex_);
  while (running_ && ros::ok() && lockstep_) {
    const double now = ros::WallTime::now().toSec();
    dropLateLocked(now);
    if (lockstep_->phase() == Phase::Sense && lockstep_->phaseComplete()) {
      act_began_ = std::chrono::steady_clock::now();
      if (!last_tick_idle_) timing_.addSensing(std::chrono::duration<double>(act_began_ - sense_began_).count(), sense_owed_);
      publishTickLocked(LockstepTick::ACT, lockstep_->startAct(now));
      continue;
    }
    // Idle ticks are for participants' timers: with nobody taking part, time moves only through ~step.
    const bool complete = lockstep_->phase() == Phase::Act && lockstep_->phaseComplete() && !paused_ &&
                          (lockstep_->wantsTime() || !lockstep_->participants().empty());
    if (complete && !lockstep_->wantsTime() && !lockstep_->awaitsTick() && now - last_tick_wall_ < idle_period_) {
      lockstep_wake_.wait_for(lock, std::chrono::duration<double>(idle_period_ - (now - last_tick_wall_)));
      continue;
    }
    if (complete) {
      advanceTickLocked(now);
      continue;
    }
    // With nobody taking part, the clock announces itself: participants of an older clock (this simulator
    // restarted while their managers lived on) hear a newer one and join it; nothing else would wake them.
    if (lockstep_->participants().empty() && now - last_announce_wall_ >= 0.5) {
      last_announce_wall_ = now;
      publishTickLocked(lockstep_->phase() == Phase::Sense ? LockstepTick::SENSE : LockstepTick::ACT, {});
    }
    // Reports, joins, leaves and step requests wake it; the timeout only paces the late-participant check.
    lockstep_wake_.wait_for(lock, std::chrono::milliseconds(100));
  }
}

void XPerSim::loop() {
  if (mode_ == ClockMode::Lockstep) {
    lockstepLoop();
    return;
  }
  using Clock = std::chrono::steady_clock;
  Clock::time_point wall_anchor;
  double sim_anchor = 0;
  while (running_ && ros::ok()) {
    if (paused_ || mode_ == ClockMode::Lockstep) {
      std::unique_lock<std::mutex> lock(wake_mutex_);
      wake_.wait_for(lock, std::chrono::milliseconds(20));
      restart_pacing_ = true;
      continue;
    }
    double sim_time;
    {
      std::lock_guard<std::mutex> lock(world_mutex_);
      if (restart_pacing_) {
        wall_anchor = Clock::now();
        sim_anchor = simTimeLocked();
        restart_pacing_ = false;
      }
      stepLocked();
      sim_time = simTimeLocked();
    }
    if (mode_ == ClockMode::RealTime) {
      // Pace simulated time against the wall clock from the last anchor, so pauses and resets don't
      // make it race to catch up.
      const auto due = wall_anchor + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>((sim_time - sim_anchor) / real_time_factor_));
      if (Clock::now() - due > std::chrono::milliseconds(20)) {
        // Fell behind (the machine was busy): go on from now instead of publishing the missed frames in
        // a burst that would overflow subscribers' queues. Simulated time runs slow for that moment.
        restart_pacing_ = true;
      } else {
        std::this_thread::sleep_until(due);
      }
    }
  }
}

void XPerSim::fillStatus(ComponentStatus& status) {
  PartStatus physics;
  physics.name = "physics";
  std::lock_guard<std::mutex> lock(world_mutex_);
  if (!world_) return;
  physics.state = status.state;
  physics.state_name = status.state_name;
  physics.message = std::string(toString(mode_)) + (paused_ ? ", paused" : "") + ", t=" +
                    core::describeNumber(simTimeLocked()) + " s, " + std::to_string(blow_ups_) + " blow-ups recovered" +
                    (lockstep_ ? ", tick " + std::to_string(lockstep_->tick()) + " (" + std::to_string(idle_ticks_) + " idle)" : std::string());
  if (!halted_.empty()) {
    physics.health = ComponentStatus::HEALTH_ERROR;
    physics.message += "; " + halted_;
    status.health = std::max(status.health, static_cast<std::uint8_t>(ComponentStatus::HEALTH_ERROR));
  } else if (ros::WallTime::now().toSec() - last_problem_wall_ < 5.0) {
    // A recent blow-up is worth a warning for a while, with what happened.
    physics.health = ComponentStatus::HEALTH_WARN;
    physics.message += "; last: " + last_problem_;
    if (status.health == ComponentStatus::HEALTH_OK) status.health = ComponentStatus::HEALTH_WARN;
  }
  status.parts.push_back(physics);
  if (lockstep_ && timing_.ticks > 0) {
    PartStatus timing;
    timing.name = "lockstep_timing";
    timing.state = status.state;
    timing.state_name = status.state_name;
    timing.message = timing_.describe();
    status.parts.push_back(timing);
  }
}

}  // namespace xpersif
