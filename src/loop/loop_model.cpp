#include "xpersif/loop/loop_model.h"

#include "xpersif/ros/setup_loader.h"
#include "xpersif/core/common/random_stream.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <tuple>

#include "xpersif/ChooseFeatures.h"
#include "xpersif/ChoosePush.h"
#include "xpersif/DesignExperiment.h"
#include "xpersif/DesignGoal.h"
#include "xpersif/ExecutePlanAction.h"
#include "xpersif/FinishRun.h"
#include "xpersif/GetFeatures.h"
#include "xpersif/GetWorldState.h"
#include "xpersif/MakePlan.h"
#include "xpersif/Predict.h"
#include "xpersif/RecordExperiment.h"
#include "xpersif/RecordGoal.h"
#include "xpersif/RecordWorldState.h"
#include "xpersif/SelectFeatures.h"
#include "xpersif/SetPose.h"
#include "xpersif/StartRun.h"
#include "xpersif/UseFeatures.h"
#include "xpersif/WorldState.h"
#include "xpersif/component/action_wait.h"
#include "xpersif/component/parameter_reader.h"
#include "xpersif/core/learning/motivation.h"
#include "xpersif/ros/experiment_conversions.h"

namespace xpersif {

namespace {

/// a - b for yaws folded modulo @p period (a cube's yaw is only known up to quarter turns).
double foldedDifference(double a, double b, double period) {
  double d = std::remainder(a - b, period);
  return d <= -period / 2 ? d + period : d;
}

std::string describe(const Experiment& e) {
  std::ostringstream out;
  out << "push " << e.object << " on " << e.side << " by " << e.distance << " m at offset " << e.offset << " m";
  return out.str();
}

std::string literalNumber(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

}  // namespace

LoopModel::LoopModel(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Supervisor(std::move(nh), std::move(private_nh), "xpersif/LoopModelNodelet") {
  core::Contract run_contract;
  run_contract.name = "run";
  run_contract.kind = core::Contract::Kind::Command;
  run_contract.interface_type = "xpersif/RunLoopAction";
  run_contract.description = "run the cognitive loop: experiments, then goals, recorded in the knowledge base";
  run_contract.parameters = {"?name", "?design"};
  run_contract.preconditions = {{"valid_run(?design)", "the design must be a declared experiment design (curiosity, "
                                                       "random, grid, or another package's), the plan valid"},
                                {"idle(loop)", "no other run may be in progress"}};
  run_contract.effects = {"finished(?name)", "learned(?name)"};
  ContractChecker<RunLoopGoal> checker(run_contract);
  checker
      .bind([](const RunLoopGoal& g) { return core::Bindings{{"?name", g.name}, {"?design", g.design}}; })
      .check("valid_run(?design)",
             [this](const RunLoopGoal& g) {
               std::string why;
               {
                 std::lock_guard<std::mutex> lock(designs_mutex_);
                 why = designs_.whyNot("goal.design", g.design);
               }
               if (why.empty()) why = core::checkMaxSize("goal.plan", g.plan.size(), 1000);
               for (std::size_t i = 0; why.empty() && i < g.plan.size(); ++i) {
                 why = core::checkExperiment("goal.plan[" + std::to_string(i) + "]", fromMsg(g.plan[i]));
               }
               if (why.empty()) why = core::checkInRange("goal.experiments", g.experiments, 0, 100000);
               if (why.empty()) why = core::checkInRange("goal.goals", g.goals, 0, 10000);
               if (why.empty()) why = core::checkMaxSize("goal.provenance", g.provenance.size(), 1 << 20);
               // A cheap shape check; the knowledge base's json_valid is the full one.
               if (why.empty() && !g.provenance.empty() && (g.provenance.front() != '{' || g.provenance.back() != '}')) {
                 why = "goal.provenance must be a JSON object or empty";
               }
               return why;
             })
      .check("idle(loop)", [this](const RunLoopGoal&) {
        return running_ ? "a run is in progress; stop it first" : std::string();
      });
  addCommand<RunLoopAction>(
      checker, [](const RunLoopGoal& g) { core::requireIdentifier("goal.name", g.name); },
      [this](Run::Context& context, RunLoopResult& result) { return run(context, result); });

  auto trigger = [this](const std::string& name, const std::string& description, const std::string& precondition,
                        const std::string& precondition_text, const std::string& effect,
                        std::function<std::string()> check, std::function<void()> act) {
    core::Contract c;
    c.name = name;
    c.kind = core::Contract::Kind::Operation;
    c.interface_type = "std_srvs/Trigger";
    c.description = description;
    c.preconditions = {{precondition, precondition_text}};
    c.effects = {effect};
    ContractChecker<std_srvs::Trigger::Request> contract(c);
    contract.check(precondition, [check](const std_srvs::Trigger::Request&) { return check(); });
    addOperation<std_srvs::Trigger>(
        contract, nullptr,
        [act](const std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
          act();
          response.message = "ok";
        });
  };
  trigger("pause", "pause the run after the current step", "running(loop)", "a run must be in progress",
          "paused(loop)", [this] { return running_ ? "" : "no run is in progress"; },
          [this] { paused_ = true; });
  trigger("resume", "resume a paused run", "paused(loop)", "the run must be paused", "not paused(loop)",
          [this] { return paused_ ? "" : "the run is not paused"; }, [this] { paused_ = false; });
  trigger("stop", "stop the run after the current step; it can be resumed later", "running(loop)",
          "a run must be in progress", "stopped(loop)", [this] { return running_ ? "" : "no run is in progress"; },
          [this] { stop_requested_ = true; });
  trigger("confirm", "let the waiting experiment go ahead (sliding autonomy)", "waiting(loop)",
          "the loop must be waiting for a confirmation", "confirmed(loop)",
          [this] { return waiting_confirmation_ ? "" : "the loop is not waiting for a confirmation"; },
          [this] { ++confirmations_; });

  core::Contract next;
  next.name = "set_next_experiment";
  next.kind = core::Contract::Kind::Operation;
  next.interface_type = "xpersif/SetExperiment";
  next.description = "run this experiment next instead of the designed one (sliding autonomy)";
  next.parameters = {"?object", "?side"};
  next.effects = {"next_experiment(?object, ?side)"};
  ContractChecker<SetExperiment::Request> next_contract(next);
  next_contract.bind([](const SetExperiment::Request& r) {
    return core::Bindings{{"?object", r.experiment.object}, {"?side", r.experiment.side}};
  });
  addOperation<SetExperiment>(
      next_contract,
      [this](const SetExperiment::Request& r) {
        core::requireExperiment("experiment", fromMsg(r.experiment));
        core::throwIfInvalid(catalogue().checkExperiment("experiment", fromMsg(r.experiment)));
      },
      [this](const SetExperiment::Request& r, SetExperiment::Response& response) {
        std::lock_guard<std::mutex> lock(mutex_);
        next_experiments_.push_back(r.experiment);
        response.message = "queued as number " + std::to_string(next_experiments_.size());
      });
}

const core::ParameterTable& LoopModel::parameters() {
  using core::ParameterSpec;
  static const core::ParameterTable table = [] {
    core::ParameterTable own(
        "loop_model",
        {core::textParameter("pose_source", "observation",
                             "where the embodiment's commands take the robot's pose from", {"odometry", "observation"}),
         core::intParameter("retries", 1, 0, 10, "EXECUTION's retries of a failed step"),
         core::flagParameter("tidy", true, "tidy the arena between experiments as an experimenter would"),
         core::flagParameter("arrange_at_start", true,
                             "a new run starts with the objects and the robot where the world file puts them"),
         core::derivedParameter(ParameterSpec::Type::Double, "tidy_margin",
                                "c + 3.25 R (SetupCatalogue::wallMargin)", 0.0, INFINITY,
                                "m: objects closer to a wall are put back (at most half the arena's smaller extent)"),
         core::derivedParameter(ParameterSpec::Type::Double, "tidy_spacing",
                                "2 c + 2.25 R (SetupCatalogue::objectSpacing)", 0.0, INFINITY,
                                "m: objects closer to each other are moved apart (at most the arena's smaller extent)"),
         core::numberParameter("goal_tolerance", 0.02, 0.005, 0.5,
                               "m: a goal is reached when the object's centre is this close to the target"),
         core::intParameter("max_goal_pushes", 5, 1, 50, "pushes a goal may take"),
         core::numberParameter("learning_timeout", 20.0, 1e-3, 3600.0,
                               "s of wall time to wait for MACHINELEARNING's model of the latest experiment"),
         core::intParameter("select_features_after", 16, 0, 100000,
                            "FEATURESELECTION chooses the features learned from once a run has this many experiments "
                            "and goes on (0: never)")});
    own.include(Supervisor::parameters()).include(LockstepClient::parameters());
    return own;
  }();
  return table;
}

void LoopModel::onConfigure() {
  ros::NodeHandle& pnh = privateNodeHandle();
  const ParameterReader parameters(pnh, LoopModel::parameters());
  EmbodimentSetup setup = loadEmbodimentSetup(nodeHandle());
  const std::string pose_source = parameters.get<std::string>("pose_source");
  const int retries = parameters.get<int>("retries");
  const bool tidy = parameters.get<bool>("tidy");
  const bool arrange = parameters.get<bool>("arrange_at_start");
  // Tidying's margins are derived from the objects, the robot and the arena (SetupCatalogue) unless set (-1).
  const double tidy_margin = parameters.get<double>("tidy_margin", -1.0);
  const double tidy_spacing = parameters.get<double>("tidy_spacing", -1.0);
  const double arena_half = 0.5 * std::min(setup.arena.size_x, setup.arena.size_y);
  if (tidy_spacing >= 0) core::requireInRange("~tidy_spacing", tidy_spacing, 0.0, 2 * arena_half);
  const int select_features_after = parameters.get<int>("select_features_after");
  if (tidy_margin >= 0) core::requireInRange("~tidy_margin", tidy_margin, 0.0, arena_half);
  const double goal_tolerance = parameters.get<double>("goal_tolerance");
  const int max_goal_pushes = parameters.get<int>("max_goal_pushes");
  const double learning_timeout = parameters.get<double>("learning_timeout");
  {
    std::lock_guard<std::mutex> lock(mutex_);
    setup_ = setup;
    std::lock_guard<std::mutex> catalogue_lock(catalogue_mutex_);
    catalogue_.reset();
    pose_source_ = pose_source;
    retries_ = retries;
    tidy_ = tidy;
    arrange_at_start_ = arrange;
    tidy_margin_ = tidy_margin;
    tidy_spacing_ = tidy_spacing;
    goal_tolerance_ = goal_tolerance;
    max_goal_pushes_ = max_goal_pushes;
    learning_timeout_ = learning_timeout;
    select_features_after_ = static_cast<std::uint32_t>(select_features_after);
    progress_.state = "idle";
    if (!progress_pub_) progress_pub_ = pnh.advertise<RunLoopFeedback>("progress", 1, true);
  }
  lockstep_ = std::make_unique<LockstepClient>(nodeHandle(), pnh, pnh.getNamespace(), false);
  model_sub_ = nodeHandle().subscribe<LearnedModel>("machine_learning/model", 1, [this](const LearnedModel::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    model_samples_ = m->samples;
  });
  publishProgress(nullptr);
  Supervisor::onConfigure();
}

// ---- helpers --------------------------------------------------------------------------------------------

namespace {
/// Call a service of another component from the loop's own thread; "" or why it failed, with the outcome's
/// xpersif/ResultCode in @p code (UNAVAILABLE when the service is not offered or does not answer).
template <class Service>
std::string call(ros::NodeHandle& nh, const std::string& name, Service& service, std::uint8_t* code = nullptr) {
  const std::string resolved = nh.resolveName(name);
  std::uint8_t ignored = 0;
  std::uint8_t& result = code ? *code : ignored;
  result = ResultCode::UNAVAILABLE;
  if (!ros::service::waitForService(resolved, ros::Duration(10.0))) return "service " + resolved + " is not offered";
  if (!ros::service::call(resolved, service)) return "service " + resolved + " did not answer";
  result = service.response.code;
  if (!service.response.success) return resolved + ": " + service.response.message;
  return "";
}
/// The same, patient with a component that is being restarted (LOOPMODEL brings it back) or not ready yet:
/// retries while the answer is UNAVAILABLE or NOT_ACTIVE (and, with @p unmet_too, PRECONDITION_FAILED: the PLANNER
/// still reading contracts, DESIGNOFEXPERIMENTS before its first feature vector), for up to @p patience seconds
/// or until @p stop says so.
template <class Service>
std::string callPatiently(ros::NodeHandle& nh, const std::string& name, Service& service, double patience = 60.0,
                          bool unmet_too = false, const std::function<bool()>& stop = {}) {
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(patience);
  std::uint8_t code = ResultCode::OK;
  std::string why = call(nh, name, service, &code);
  while (!why.empty() && ros::ok() && ros::WallTime::now() < until && !(stop && stop()) &&
         (code == ResultCode::UNAVAILABLE || code == ResultCode::NOT_ACTIVE ||
          (unmet_too && code == ResultCode::PRECONDITION_FAILED))) {
    ros::WallDuration(0.2).sleep();
    why = call(nh, name, service, &code);
  }
  return why;
}
/// Patient also with an unmet precondition, which a component just (re)started may not meet yet.
template <class Service>
std::string callWhenReady(ros::NodeHandle& nh, const std::string& name, Service& service,
                          const std::function<bool()>& stop) {
  return callPatiently(nh, name, service, 60.0, true, stop);
}

}  // namespace

void LoopModel::setState(const std::string& state) {
  std::lock_guard<std::mutex> lock(mutex_);
  progress_.state = state;
}

void LoopModel::publishProgress(Run::Context* context) {
  RunLoopFeedback progress;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    progress = progress_;
  }
  if (progress_pub_) progress_pub_.publish(progress);
  if (context) context->publishFeedback(progress);
}

bool LoopModel::getScene(FeatureVector* scene, std::string* why) {
  Spending spending(wall_spent_, "scene");
  // The scene as it is now: VISION works behind the camera, so its latest vector may show an older world (in
  // lockstep the next idle tick brings a frame of the standing world).
  double newer_than = ros::Time::now().toSec();
  // 10 s of wall time while simulated time moves: a paused XPERSim (someone watching a frame) stops the clock,
  // and a wait for a new frame then waits as long as the pause (it once aborted the run after 10 s).
  ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(10.0);
  ros::WallTime last_wall = ros::WallTime::now();
  ros::Time last_sim = ros::Time::now();
  const ros::WallTime give_up = last_wall + ros::WallDuration(600.0);  // a clock that never moves again
  while (ros::ok()) {
    const ros::WallTime wall_now = ros::WallTime::now();
    if (ros::Time::now() == last_sim) deadline += wall_now - last_wall;  // the clock stood still meanwhile
    last_wall = wall_now;
    last_sim = ros::Time::now();
    // Simulated time that went backwards means XPERSim was restarted (its manager died and was respawned): its
    // clock began again, and the world standing now is the restarted one; a frame newer than that is the scene.
    newer_than = std::min(newer_than, ros::Time::now().toSec());
    GetFeatures features;
    features.request.max_age = 2.0;
    *why = call(nodeHandle(), "vision/get_features", features);
    if (why->empty() && features.response.features.header.stamp.toSec() > newer_than) {
      *scene = features.response.features;
      return true;
    }
    if (ros::WallTime::now() > deadline || ros::WallTime::now() > give_up) {
      if (why->empty()) {
        *why = ros::WallTime::now() > give_up
                   ? "no new observation of the scene came within 600 s: the simulator's clock stood still"
                   : "no new observation of the scene came within 10 s while simulated time went on";
      }
      return false;
    }
    // (In lockstep the clock's idle ticks bring new frames of the standing world: no physics time is asked for.)
    ros::WallDuration(0.02).sleep();
  }
  *why = "shutting down";
  return false;
}

const core::SetupCatalogue& LoopModel::catalogue() {
  std::lock_guard<std::mutex> lock(catalogue_mutex_);
  if (!catalogue_) catalogue_ = loadSetupCatalogue(nodeHandle(), privateNodeHandle());
  return *catalogue_;
}

int LoopModel::tidyArena(const FeatureVector& scene, std::uint64_t stream) {
  Spending spending(wall_spent_, "tidy");
  std::mt19937_64 rng(stream);
  std::vector<std::string> misplaced;
  int moved = 0;
  std::vector<std::pair<double, double>> occupied;
  for (const auto& o : scene.objects) occupied.emplace_back(o.position.x, o.position.y);
  if (scene.robot_found) occupied.emplace_back(scene.robot.x, scene.robot.y);
  try {
    catalogue();
  } catch (const std::exception& e) {
    ROS_WARN("%s: cannot tidy the arena: %s", name().c_str(), e.what());
    return 0;
  }
  const double margin = tidy_margin_ >= 0 ? tidy_margin_ : catalogue_->wallMargin();
  const double spacing = tidy_spacing_ >= 0 ? tidy_spacing_ : catalogue_->objectSpacing();
  const double hx = catalogue_->arena_size_x / 2 - margin, hy = catalogue_->arena_size_y / 2 - margin;
  if (hx <= 0 || hy <= 0) {
    ROS_WARN("%s: cannot tidy the arena: a margin of %.3f m from the walls leaves no room", name().c_str(), margin);
    return 0;
  }
  const std::vector<std::string> names = catalogue_->names();
  for (const auto& name : names) {
    const ObjectFeatures* o = findObject(scene, name);
    if (!o || std::abs(o->position.x) > hx || std::abs(o->position.y) > hy) {
      misplaced.push_back(name);
      continue;
    }
    // Cubes pushed together leave no room for the robot at their faces: the later one of a close pair moves.
    for (const auto& other : scene.objects) {
      if (other.name >= name || !catalogue_->find(other.name)) continue;
      if (std::hypot(other.position.x - o->position.x, other.position.y - o->position.y) < spacing) {
        misplaced.push_back(name);
        break;
      }
    }
  }
  // A misplaced cube's old spot no longer counts as occupied.
  occupied.clear();
  for (const auto& o : scene.objects) {
    if (std::find(misplaced.begin(), misplaced.end(), o.name) == misplaced.end()) occupied.emplace_back(o.position.x, o.position.y);
  }
  if (scene.robot_found) occupied.emplace_back(scene.robot.x, scene.robot.y);
  for (const auto& name : misplaced) {
    std::uniform_real_distribution<double> ux(-hx, hx), uy(-hy, hy);
    for (int attempt = 0; attempt < 200; ++attempt) {
      const double x = ux(rng), y = uy(rng);
      bool free = true;
      for (const auto& [ox, oy] : occupied) free = free && std::hypot(x - ox, y - oy) > spacing;
      if (!free) continue;
      SetPose place;
      place.request.name = name;
      place.request.pose.position.x = x;
      place.request.pose.position.y = y;
      place.request.pose.orientation.w = 1.0;
      place.request.on_floor = true;
      const std::string why = call(nodeHandle(), "xpersim/set_pose", place);
      if (!why.empty()) {
        ROS_WARN("%s: could not tidy %s away: %s", name.c_str(), this->name().c_str(), why.c_str());
      } else {
        events().publish(events().make(ComponentEvent::SUPERVISION, "tidy", "ok",
                                       "put " + name + " back at (" + literalNumber(x) + ", " + literalNumber(y) + ")"));
        occupied.emplace_back(x, y);
        ++moved;
      }
      break;
    }
  }
  return moved;
}

std::string LoopModel::arrangeInitialScene() {
  // XPERSim refuses a place another body occupies (PRECONDITION_FAILED). A body whose start is taken (by a body
  // that has yet to go to its own) is parked 1 m above its start, where nothing is, and set down once every
  // body has its place: the world file's start poses never overlap, so that always succeeds. Parked bodies do
  // not fall meanwhile: no physics step runs between these calls (an idle tick does not step).
  std::vector<std::string> parked;
  auto place = [&](const std::string& name, const core::Pose2D& pose, bool parking) {
    SetPose request;
    request.request.name = name;
    request.request.pose.position.x = pose.x;
    request.request.pose.position.y = pose.y;
    request.request.pose.position.z = parking ? 1.0 : 0.0;
    request.request.pose.orientation.z = std::sin(pose.yaw / 2);
    request.request.pose.orientation.w = std::cos(pose.yaw / 2);
    request.request.on_floor = !parking;
    std::uint8_t code = ResultCode::OK;
    const std::string why = call(nodeHandle(), "xpersim/set_pose", request, &code);
    return std::make_pair(why, code);
  };
  for (const auto& [name, pose] : setup_.initial_poses) {
    auto [why, code] = place(name, pose, false);
    if (!why.empty() && code == ResultCode::PRECONDITION_FAILED) {
      std::tie(why, code) = place(name, pose, true);
      if (why.empty()) parked.push_back(name);
    }
    if (!why.empty()) return why;
  }
  for (const auto& name : parked) {
    const auto [why, code] = place(name, setup_.initial_poses.at(name), false);
    if (!why.empty()) return why;
  }
  return "";
}

std::vector<std::string> LoopModel::learningFeatures() {
  std::lock_guard<std::mutex> lock(mutex_);
  return learning_features_;
}

std::uint32_t LoopModel::modelSamples() {
  std::lock_guard<std::mutex> lock(mutex_);
  return model_samples_;
}

void LoopModel::waitForLearning(std::uint32_t samples, Run::Context& context) {
  Spending spending(wall_spent_, "learning");
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(learning_timeout_);
  while (ros::WallTime::now() < deadline && !context.stopRequested()) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (model_samples_ >= samples) return;
    }
    ros::WallDuration(0.01).sleep();
  }
  ROS_WARN("%s: MACHINELEARNING has not learned experiment %u within %.0f s; going on", name().c_str(), samples,
           learning_timeout_);
}

std::string LoopModel::waitForSelection(const std::vector<std::string>& selection) {
  Spending spending(wall_spent_, "features");
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(20.0);
  std::string why;
  while (ros::ok()) {
    GetFeatures features;
    features.request.max_age = 0.0;
    why = call(nodeHandle(), "vision/get_features", features);
    if (why.empty()) {
      const auto& objects = features.response.features.objects;
      const bool carried = !objects.empty() && std::all_of(objects.begin(), objects.end(), [&](const ObjectFeatures& o) {
        return o.feature_names == selection;
      });
      if (carried) return "";
      why = "its vectors do not carry the selection yet";
    }
    if (ros::WallTime::now() > deadline) break;
    // (In lockstep the clock's idle ticks bring new frames of the standing world.)
    ros::WallDuration(0.02).sleep();
  }
  return "VISION did not take up the selection within 20 s: " + why;
}

std::string LoopModel::ensureFeatures(std::uint64_t run_id, std::uint64_t seed, std::uint32_t done,
                                      std::uint32_t experiments, FeatureStage& stage) {
  const std::uint32_t after = std::min(select_features_after_, experiments);
  const int target = after > 0 && done >= after ? 1 : 0;
  const std::uint64_t losses = losses_;
  if (stage.applied == target && stage.losses == losses) return "";
  std::string why;
  std::vector<std::string> learn, selection;  // learn empty: MACHINELEARNING's ~features
  bool chosen = false;
  if (target == 1) {
    // Ranked on what the knowledge base holds of the run's first experiments: a resumed run chooses the same.
    ChooseFeatures choose;
    choose.request.run_id = run_id;
    choose.request.experiments = after;
    choose.request.seed = core::streamSeed(seed, run_id, after, core::StreamPurpose::Features);
    {
      Spending spending(wall_spent_, "features");
      why = callPatiently(nodeHandle(), "feature_selection/choose_features", choose);
    }
    if (why.empty()) {
      chosen = true;
      learn = choose.response.chosen;
      selection = choose.response.selected;
      ROS_INFO("%s: run %lu: %s", name().c_str(), static_cast<unsigned long>(run_id), choose.response.message.c_str());
    } else if (choose.response.code == ResultCode::FAILED) {
      ROS_WARN("%s: run %lu goes on with the initial features: FEATURESELECTION made no choice: %s", name().c_str(),
               static_cast<unsigned long>(run_id), why.c_str());
    } else {
      return "FEATURESELECTION's choose_features: " + why;
    }
  }
  if (!chosen) {
    SelectFeatures initial;  // none: FEATURESELECTION's initial selection
    {
      Spending spending(wall_spent_, "features");
      why = callPatiently(nodeHandle(), "feature_selection/select_features", initial);
    }
    if (!why.empty()) return "FEATURESELECTION's select_features: " + why;
    selection = initial.response.selected;
  }
  UseFeatures use;
  use.request.names = learn;
  use.request.initial = !chosen;
  {
    Spending spending(wall_spent_, "features");
    why = callPatiently(nodeHandle(), "machine_learning/use_features", use);
  }
  if (!why.empty()) return "MACHINELEARNING's use_features: " + why;
  why = waitForSelection(selection);
  if (!why.empty()) return why;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    learning_features_ = use.response.features;
  }
  stage.applied = target;
  stage.losses = losses;
  return "";
}

void LoopModel::onComponentLost(const SupervisedComponent& component, const std::string& reason) {
  (void)component;
  (void)reason;
  ++losses_;
}

std::string LoopModel::checkpointWorld(std::string* why) {
  Spending spending(wall_spent_, "checkpoint");
  WorldState checkpoint;
  *why = callPatiently(nodeHandle(), "xpersim/checkpoint", checkpoint);
  if (why->empty()) world_lineage_ = checkpoint.response.lineage;
  return checkpoint.response.state;
}

std::string LoopModel::storeWorldState(std::uint64_t run_id, std::uint32_t step, const std::string& state) {
  Spending spending(wall_spent_, "checkpoint");
  RecordWorldState record;
  record.request.run_id = run_id;
  record.request.step = step;
  record.request.state = state;
  return callPatiently(nodeHandle(), "knowledge_base/record_world_state", record);
}

std::string LoopModel::takeCheckpoint(std::uint64_t run_id, std::uint32_t step, std::string* refused) {
  std::string why;
  const std::string state = checkpointWorld(&why);
  if (why.empty()) {
    why = storeWorldState(run_id, step, state);
    // A knowledge base that cannot store (its disk full or read-only) will not store the step's results either:
    // the caller ends the run before the step, so that it can be resumed from here once the disk is fixed.
    if (!why.empty()) {
      *refused = why;
      return state;
    }
  }
  if (!why.empty()) {
    ROS_WARN("%s: no world state at step %u (a resume from there will start from the world as it is then): %s",
             name().c_str(), step, why.c_str());
  }
  return state;
}

std::string LoopModel::restoreCheckpoint(std::uint64_t run_id, std::uint32_t step, const std::string& state) {
  Spending spending(wall_spent_, "checkpoint");
  WorldState restore;
  restore.request.state = state;
  // Time goes on after the latest the loop saw, plus a margin for what others saw after it.
  restore.request.min_clock = latest_clock_ + 1.0;
  if (state.empty()) {
    GetWorldState stored;
    stored.request.run_id = run_id;
    stored.request.step = step;
    std::string why = callPatiently(nodeHandle(), "knowledge_base/get_world_state", stored);
    if (!why.empty()) return why;
    if (!stored.response.found) return "no world state is stored for step " + std::to_string(step);
    restore.request.state = stored.response.state;
  }
  const std::string why = callPatiently(nodeHandle(), "xpersim/restore", restore);
  if (why.empty()) world_lineage_ = restore.response.lineage;
  return why;
}

bool LoopModel::lostDuring(std::uint64_t losses_before, const ExperimentRecord& record) {
  // A failure may be the first sign of a lost component: give the supervisor its heartbeat timeout to tell.
  if (record.status != "done" && losses_ == losses_before) ros::WallDuration(heartbeatTimeout() + 0.5).sleep();
  return losses_ != losses_before;
}

std::string LoopModel::returnTo(Run::Context& context, std::uint64_t run_id, const std::string& state) {
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(180.0);
  std::vector<std::string> lost = lostComponents();
  while (!lost.empty()) {
    if (context.stopRequested()) return "stopped while components were lost";
    if (ros::WallTime::now() > until) {
      std::string names;
      for (const auto& n : lost) names += (names.empty() ? "" : ", ") + n;
      return names + " did not come back within 180 s";
    }
    ros::WallDuration(0.1).sleep();
    lost = lostComponents();
  }
  return restoreCheckpoint(run_id, 0, state);
}

std::string LoopModel::gate(Run::Context& context, bool confirm_each) {
  auto stopping = [&]() -> std::string {
    if (context.cancelRequested()) return "cancelled";
    if (context.stopRequested()) return "component stopping";
    if (stop_requested_) return "stopped on request";
    return "";
  };
  std::string why = stopping();
  if (!why.empty()) return why;
  if (paused_) {
    setState("paused");
    publishProgress(&context);
    while (paused_ && (why = stopping()).empty()) ros::WallDuration(0.02).sleep();
    if (!why.empty()) return why;
  }
  if (confirm_each) {
    const int seen = confirmations_;
    waiting_confirmation_ = true;
    setState("waiting_for_confirmation");
    publishProgress(&context);
    while (confirmations_ == seen && (why = stopping()).empty()) ros::WallDuration(0.02).sleep();
    waiting_confirmation_ = false;
    if (!why.empty()) return why;
  }
  return "";
}

// ---- one experiment -------------------------------------------------------------------------------------

void LoopModel::runExperiment(const Experiment& experiment, const std::string& design, Run::Context& context,
                              ExperimentRecord& record) {
  record.design = design;
  record.experiment = experiment;
  record.status = "failed";
  record.started = ros::Time::now().toSec();
  auto fail = [&](const std::string& why) {
    record.reason = why;
    record.finished = ros::Time::now().toSec();
  };

  // Plan from the contracts: observe, push, observe again.
  MakePlan plan;
  plan.request.goal = {"pushed(" + experiment.object + ", " + experiment.side + ", " + literalNumber(experiment.offset) +
                           ", " + literalNumber(experiment.distance) + ")",
                       "observed(scene)"};
  std::optional<Spending> spending(std::in_place, wall_spent_, "plan");
  // Right after start-up the PLANNER may still be reading the components' contracts (contracts_loaded).
  std::string why = callWhenReady(nodeHandle(), "planner/make_plan", plan, [&] { return context.stopRequested(); });
  if (!why.empty()) return fail("no plan: " + why);

  if (!execution_) {
    execution_ = std::make_unique<actionlib::SimpleActionClient<ExecutePlanAction>>(nodeHandle(), "execution/execute_plan", false);
  }
  auto& execution = *execution_;
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(20.0);
  while (!execution.isServerConnected() && ros::WallTime::now() < until) ros::WallDuration(0.01).sleep();
  if (!execution.isServerConnected()) return fail("EXECUTION's execute_plan is not offered");
  ExecutePlanGoal goal;
  goal.steps = plan.response.steps;
  goal.pose_source = pose_source_;
  goal.retries = static_cast<std::uint32_t>(retries_);
  // What the plan reaches and what held when it was made: a step that still fails is replanned around
  // (EXECUTION's ~max_replans).
  goal.goal = plan.request.goal;
  goal.state = plan.request.state;
  spending.emplace(wall_spent_, "execution");
  const std::uint64_t losses_before = losses_;
  execution.sendGoal(goal);
  while (!execution.getState().isDone()) {
    latest_clock_ = std::max(latest_clock_, ros::Time::now().toSec());
    // A lost component ends the experiment at once: it will be done again from its world state, and what the
    // plan does meanwhile (against a restarted simulator whose clock starts from zero) would only cost time.
    const bool lost = losses_ != losses_before;
    if (context.stopRequested() || lost) {
      execution.cancelGoal();
      waitForResultOnWallTime(execution, ros::WallDuration(10.0));
      return fail(lost ? "a component was lost during execution" : "stopped during execution");
    }
    ros::WallDuration(0.01).sleep();
  }
  const auto result = execution.getResult();
  if (execution.getState() != actionlib::SimpleClientGoalState::SUCCEEDED || !result || !result->success) {
    return fail("execution failed: " + execution.getState().getText());
  }
  if (result->observations.size() < 2) return fail("the plan made fewer than two observations");
  record.before = result->observations.front();
  record.after = result->observations.back();
  const ObjectFeatures* before = findObject(record.before, experiment.object);
  const ObjectFeatures* after = findObject(record.after, experiment.object);
  if (!before || !after) return fail("the overhead camera lost " + experiment.object + " during the experiment");

  // What the model expected (it has not seen this experiment yet) ...
  spending.emplace(wall_spent_, "predict");
  Predict predict;
  predict.request.experiment = experiment;
  predict.request.object = *before;
  why = callPatiently(nodeHandle(), "machine_learning/predict", predict);
  if (!why.empty()) return fail("no prediction: " + why);
  record.predicted_mean = predict.response.mean;
  record.predicted_std = predict.response.std;

  // ... and what happened, in the push frame.
  core::ObjectFeatures b = fromMsg(*before), a = fromMsg(*after);
  const double period = before->yaw_period > 0 ? before->yaw_period : 2 * M_PI;
  a.yaw = b.yaw + foldedDifference(a.yaw, b.yaw, period);
  try {
    const core::Outcome outcome = core::computeOutcome(b, a, experiment.side);
    record.dx = outcome.dx;
    record.dy = outcome.dy;
    record.dyaw = outcome.dyaw;
    core::Prediction prediction;
    prediction.mean = {record.predicted_mean.at(0), record.predicted_mean.at(1), record.predicted_mean.at(2)};
    prediction.std = {record.predicted_std.at(0), record.predicted_std.at(1), record.predicted_std.at(2)};
    record.surprise = core::surprise(prediction, outcome).error;
  } catch (const std::exception& e) {
    return fail(std::string("cannot compute the outcome: ") + e.what());
  }
  record.status = "done";
  record.finished = ros::Time::now().toSec();
}

// ---- the run --------------------------------------------------------------------------------------------

CommandOutcome LoopModel::run(Run::Context& context, RunLoopResult& result) {
  const RunLoopGoal& goal = context.goal();
  running_ = true;
  paused_ = false;
  stop_requested_ = false;
  // However the run ends: not running, and hand-chosen experiments it did not reach do not carry over.
  struct Running {
    LoopModel& loop;
    ~Running() {
      loop.running_ = false;
      std::lock_guard<std::mutex> lock(loop.mutex_);
      loop.next_experiments_.clear();
    }
  } running{*this};
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& e : goal.plan) next_experiments_.push_back(e);
    progress_ = RunLoopFeedback();
  }

  wall_spent_.clear();
  const ros::WallTime run_started = ros::WallTime::now();
  // A LOOPMODEL just restarted is sent the run again as soon as it offers `run`, while its components are still
  // starting: the run waits for all of them (each step of a bring-up is bounded by ~startup_timeout), rather than
  // for one service at a time with a patience that a slow restart outlasts.
  std::string why;
  {
    Spending spending(wall_spent_, "starting");
    setState("starting");
    publishProgress(&context);
    why = waitUntilUp(startupTimeout() * static_cast<double>(supervised().size() + 1),
                      [&] { return context.cancelRequested() || context.stopRequested() || stop_requested_; });
  }
  if (!why.empty()) return CommandOutcome::aborted(result.message = "cannot start the run: " + why);
  StartRun start;
  start.request.name = goal.name;
  start.request.seed = goal.seed;
  start.request.design = goal.design;
  start.request.resume = goal.resume;
  std::ostringstream parameters;
  parameters << "{\"experiments\":" << goal.experiments << ",\"goals\":" << goal.goals << ",\"design\":\"" << goal.design
             << "\",\"seed\":" << goal.seed << ",\"pose_source\":\"" << pose_source_ << "\",\"goal_tolerance\":"
             << literalNumber(goal_tolerance_) << ",\"max_goal_pushes\":" << max_goal_pushes_;
  // The knowledge base refuses the run (INVALID, with its sentence) if this is not a JSON object.
  if (!goal.provenance.empty()) parameters << ",\"provenance\":" << goal.provenance;
  parameters << "}";
  start.request.parameters = parameters.str();
  why = callPatiently(nodeHandle(), "knowledge_base/start_run", start);
  if (!why.empty()) return CommandOutcome::aborted(result.message = "cannot start the run: " + why);
  result.run_id = start.response.run_id;
  if (arrange_at_start_ && !start.response.resumed) {
    why = arrangeInitialScene();
    if (!why.empty()) ROS_WARN("%s: could not arrange the scene: %s", name().c_str(), why.c_str());
    lockstep_->sleepFor(ros::Duration(0.5));  // let odometry and the overhead camera see the new scene
  }
  std::uint32_t done = start.response.experiments_designed;  // counted towards goal.experiments
  std::uint32_t learned = 0;  // successful experiments the model has seen in this run
  setState("experimenting");
  {
    std::lock_guard<std::mutex> lock(mutex_);
    progress_.experiment = done;
    const auto left = [](std::uint32_t total, std::uint32_t had) { return total > had ? total - had : 0u; };
    progress_.last = (start.response.resumed ? "resumed run " : "started run ") + std::to_string(result.run_id) +
                     " (" + goal.name + "): " + std::to_string(done) + " experiments and " +
                     std::to_string(start.response.goals_done) + " goals done, " +
                     std::to_string(left(goal.experiments, done)) + " experiments and " +
                     std::to_string(left(goal.goals, start.response.goals_done)) + " goals left";
  }
  publishProgress(&context);
  auto finish = [&](const std::string& status) {
    std::ostringstream spent;
    double counted = 0;
    for (const auto& [step, seconds] : wall_spent_) {
      spent << (counted == 0 ? "" : ", ") << step << " " << core::describeNumber(seconds);
      counted += seconds;
    }
    ROS_INFO("%s: run %lu %s after %.1f s of wall time: %s, other %.1f s", name().c_str(),
             static_cast<unsigned long>(result.run_id), status.c_str(), (ros::WallTime::now() - run_started).toSec(),
             spent.str().c_str(), (ros::WallTime::now() - run_started).toSec() - counted);
    FinishRun finish_run;
    finish_run.request.run_id = result.run_id;
    finish_run.request.status = status;
    callPatiently(nodeHandle(), "knowledge_base/finish_run", finish_run);
    setState(status);
    publishProgress(&context);
  };
  auto ended = [&](const std::string& reason) {
    finish("stopped");
    result.message = reason + " after " + std::to_string(result.experiments_done) + " experiments";
    if (context.cancelRequested()) return CommandOutcome::preempted(result.message);
    return CommandOutcome::aborted(result.message);
  };

  // The world as it was at the step the run resumes at (a restarted simulator starts from the world file).
  // The step's checkpoint is then the state restored (XPERSim's checkpoint of an unchanged world), so that
  // the first step of a resumed run can be done again too.
  if (start.response.resumed) {
    const std::uint32_t step = done < goal.experiments ? done : goal.experiments + start.response.goals_done;
    why = restoreCheckpoint(result.run_id, step);
    if (why.empty()) {
      ROS_INFO("%s: resumed run %lu from the world state of step %u", name().c_str(),
               static_cast<unsigned long>(result.run_id), step);
    } else {
      ROS_WARN("%s: resuming run %lu from the world as it is: %s", name().c_str(),
               static_cast<unsigned long>(result.run_id), why.c_str());
    }
  }
  FeatureStage features;  // which features the run learns from (FEATURESELECTION's choice once it is due)
  std::string step_state;  // the world state at the start of the current step
  std::string next_state;  // the world at the end of the last step, stored already as the next one's start

  // ---- experimentation state ----
  // The knowledge base could not store: nothing of the step is done, the world is as the knowledge base says.
  auto unstored = [&](const std::string& what, const std::string& why) {
    return ended("the knowledge base did not store " + what + " (" + why + "); the run stops before it, and " +
                 "`--resume` goes on from there once the knowledge base can store again");
  };
  while (done < goal.experiments) {
    std::string refused;
    if (next_state.empty()) {
      step_state = takeCheckpoint(result.run_id, done, &refused);
      if (!refused.empty()) return unstored("the world state of experiment " + std::to_string(done + 1), refused);
    } else {
      step_state = next_state;
      next_state.clear();
    }
    const std::string lineage = world_lineage_;
    const std::uint64_t losses_before = losses_;
    why = gate(context, goal.confirm_each);
    if (!why.empty()) return ended(why);
    setState("experimenting");
    why = ensureFeatures(result.run_id, goal.seed, done, goal.experiments, features);
    if (!why.empty()) return ended("cannot set the features learned from: " + why);
    FeatureVector scene;
    if (!getScene(&scene, &why)) return ended("cannot observe the scene: " + why);
    if (tidy_) {
      if (tidyArena(scene, core::streamSeed(goal.seed, result.run_id, done, core::StreamPurpose::Tidy)) > 0 &&
          !getScene(&scene, &why)) {
        return ended("cannot observe the scene: " + why);
      }
    }
    Experiment experiment;
    std::string design = goal.design;
    bool chosen = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!next_experiments_.empty()) {
        experiment = next_experiments_.front();
        next_experiments_.pop_front();
        design = "hand";
        chosen = true;
      }
    }
    if (!chosen) {
      DesignExperiment request;
      request.request.design = goal.design;
      request.request.scored = start.response.experiments_done + learned;  // what MOTIVATION must have heard of
      request.request.seeded = true;
      request.request.stream = core::streamSeed(goal.seed, result.run_id, done, core::StreamPurpose::Design);
      request.request.experiment = done;
      request.request.run_id = result.run_id;
      // The scene, so that DESIGNOFEXPERIMENTS chooses a push that can be done from here.
      appendScenePoses(scene, &request.request.scene_objects, &request.request.scene_poses);
      Spending spending(wall_spent_, "design");
      why = callWhenReady(nodeHandle(), "design_of_experiments/design_experiment", request,
                          [&] { return context.stopRequested(); });
      if (!why.empty()) return ended("DESIGNOFEXPERIMENTS failed: " + why);
      experiment = request.response.experiment;
    }
    ExperimentRecord record;
    runExperiment(experiment, design, context, record);
    if (context.stopRequested() && record.status != "done") return ended("stopped during an experiment");
    // The world as the experiment left it is the next step's start: taken now, before anything is stored, so
    // that a simulator that died after the experiment, while nothing moved the world, is noticed too: the world
    // it gives is another one (its lineage), and the experiment is done again.
    std::string end_why, end_state = checkpointWorld(&end_why);
    const bool replaced = !lineage.empty() && end_why.empty() && world_lineage_ != lineage;
    if ((lostDuring(losses_before, record) || replaced) && !step_state.empty()) {
      // A component was lost during the experiment: what it did is not what an uninterrupted run would have
      // done. It is not stored; once every component is back, the world goes back to the step's state and the
      // same experiment (the same design stream) is done again.
      ROS_WARN("%s: a component was lost during experiment %u (%s%s); doing it again from the world as it was",
               name().c_str(), done + 1, record.status == "done" ? "it finished" : record.reason.c_str(),
               replaced ? "; the simulator's world is another one now" : "");
      why = returnTo(context, result.run_id, step_state);
      if (!why.empty()) return ended("cannot do experiment " + std::to_string(done + 1) + " again: " + why);
      if (chosen) {
        std::lock_guard<std::mutex> lock(mutex_);
        next_experiments_.push_front(experiment);
      }
      continue;
    }
    if (end_why.empty()) {  // the next step's state first: stored before the experiment, a resume never lacks it
      why = storeWorldState(result.run_id, done + 1, end_state);
      if (!why.empty()) {
        if (!step_state.empty()) restoreCheckpoint(result.run_id, done, step_state);
        return unstored("the world state after experiment " + std::to_string(done + 1), why);
      }
    }
    RecordExperiment store;
    store.request.record = record;
    store.request.record.run_id = result.run_id;
    {
      Spending spending(wall_spent_, "record");
      why = callPatiently(nodeHandle(), "knowledge_base/record_experiment", store);
    }
    if (!why.empty()) {
      // The world goes back to where the knowledge base has it: before this experiment.
      if (!step_state.empty()) restoreCheckpoint(result.run_id, done, step_state);
      return unstored("experiment " + std::to_string(done + 1), why);
    }
    if (end_why.empty()) next_state = end_state;
    ++done;
    if (record.status == "done") {
      ++result.experiments_done;
      waitForLearning(static_cast<std::uint32_t>(start.response.experiments_done) + (++learned), context);
    } else {
      ++result.experiments_failed;
      ROS_WARN("%s: experiment %u failed: %s", name().c_str(), done, record.reason.c_str());
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      progress_.experiment = done;
      progress_.surprise = record.surprise;
      progress_.last = describe(experiment) + (record.status == "done" ? "" : " (failed: " + record.reason + ")");
    }
    publishProgress(&context);
  }

  // ---- goal-directed state ----
  if (goal.goals > 0) {
    setState("goal_directed");
    publishProgress(&context);
  }
  for (std::uint32_t g = start.response.goals_done; g < goal.goals; ++g) {
    std::string refused;
    const std::string lineage_before = world_lineage_;
    takeCheckpoint(result.run_id, goal.experiments + g, &refused);
    if (!refused.empty()) return unstored("the world state of goal " + std::to_string(g + 1), refused);
    if (!lineage_before.empty() && world_lineage_ != lineage_before) {
      ROS_WARN("%s: the simulator was replaced since the last step ended; goal %u starts from the world it has now "
               "(a known gap: the world the last step left is lost)", name().c_str(), g + 1);
    }
    why = gate(context, goal.confirm_each);  // sliding autonomy holds in both phases
    if (!why.empty()) return ended(why);
    // The choice of a run of no more than ~select_features_after experiments is made here; again after a loss.
    why = ensureFeatures(result.run_id, goal.seed, done, goal.experiments, features);
    if (!why.empty()) return ended("cannot set the features learned from: " + why);
    FeatureVector scene;
    if (!getScene(&scene, &why)) return ended("cannot observe the scene: " + why);
    // Goal g's choices are numbered after the experiments, so that they never share a stream with them.
    const std::uint64_t goal_index = goal.experiments + g;
    if (tidy_) {
      if (tidyArena(scene, core::streamSeed(goal.seed, result.run_id, goal_index, core::StreamPurpose::Tidy)) > 0 &&
          !getScene(&scene, &why)) {
        return ended("cannot observe the scene: " + why);
      }
    }
    DesignGoal design;
    design.request.scene = scene;
    design.request.samples = modelSamples();
    design.request.features = learningFeatures();
    design.request.seeded = true;
    design.request.stream = core::streamSeed(goal.seed, result.run_id, goal_index, core::StreamPurpose::Goal);
    design.request.tolerance = goal_tolerance_;
    {
      Spending spending(wall_spent_, "design");
      why = call(nodeHandle(), "goal_design/design_goal", design);
    }
    if (!why.empty()) return ended("GOALDESIGN could not set a goal: " + why);
    ROS_INFO("%s: goal %u: %s", name().c_str(), g + 1, design.response.message.c_str());
    ++result.goals_tried;
    RecordGoal record_goal;
    record_goal.request.run_id = result.run_id;
    record_goal.request.object = design.response.object;
    record_goal.request.target_x = design.response.target_x;
    record_goal.request.target_y = design.response.target_y;
    double error = INFINITY;
    // A push starts from a state in memory when there is one: its own, when it is done again, or the one the last
    // push left; else from a new checkpoint.
    std::string next_push_state;
    for (int push = 0; push <= max_goal_pushes_; ++push) {
      const ObjectFeatures* object = findObject(scene, design.response.object);
      if (!object) break;
      error = std::hypot(object->position.x - design.response.target_x, object->position.y - design.response.target_y);
      if (error < goal_tolerance_ || push == max_goal_pushes_) break;
      // Each push starts from a checkpoint kept in memory: a push during which a component was lost is done again.
      std::string push_state = std::move(next_push_state);
      next_push_state.clear();
      if (push_state.empty()) {
        std::string ignored;
        push_state = checkpointWorld(&ignored);
      }
      const std::string push_lineage = world_lineage_;
      why = ensureFeatures(result.run_id, goal.seed, done, goal.experiments, features);  // again after a loss
      if (!why.empty()) return ended("cannot set the features learned from: " + why);
      ChoosePush choose;
      choose.request.samples = modelSamples();
      choose.request.features = learningFeatures();
      choose.request.scene = scene;
      choose.request.object = design.response.object;
      choose.request.target_x = design.response.target_x;
      choose.request.target_y = design.response.target_y;
      choose.request.seeded = true;
      choose.request.stream = core::streamSeed(goal.seed, result.run_id, goal_index * 1000 + push,
                                               core::StreamPurpose::GoalPush);
      {
        Spending spending(wall_spent_, "design");
        why = call(nodeHandle(), "goal_design/choose_push", choose);
      }
      if (!why.empty()) {  // the goal ends here, missed; the run goes on with the next goal
        ROS_WARN("%s: goal %u (%s): GOALDESIGN chose no push: %s", name().c_str(), g + 1,
                 design.response.object.c_str(), why.c_str());
        break;
      }
      ExperimentRecord record;
      const std::uint64_t losses_before = losses_;
      runExperiment(choose.response.experiment, "goal", context, record);
      // As after an experiment: the world the push left, taken before anything is stored, from the same simulator.
      std::string end_why, end_state = checkpointWorld(&end_why);
      const bool replaced = !push_lineage.empty() && end_why.empty() && world_lineage_ != push_lineage;
      if ((lostDuring(losses_before, record) || replaced) && !push_state.empty() && !context.stopRequested()) {
        ROS_WARN("%s: a component was lost during push %d of goal %u; doing it again from the world as it was",
                 name().c_str(), push + 1, g + 1);
        why = returnTo(context, result.run_id, push_state);
        if (!why.empty()) return ended("cannot do push " + std::to_string(push + 1) + " of goal " + std::to_string(g + 1) + " again: " + why);
        next_push_state = push_state;
        --push;
        continue;
      }
      ++record_goal.request.pushes;
      // Every goal push is stored, a failed one with its reason, as the designed experiments are.
      RecordExperiment store;
      store.request.record = record;
      store.request.record.run_id = result.run_id;
      why = callPatiently(nodeHandle(), "knowledge_base/record_experiment", store);
      if (!why.empty()) {
        if (!push_state.empty()) restoreCheckpoint(result.run_id, 0, push_state);
        return unstored("push " + std::to_string(push + 1) + " of goal " + std::to_string(g + 1), why);
      }
      if (end_why.empty()) next_push_state = end_state;  // the next push starts from the world this one left
      if (record.status == "done") {
        waitForLearning(static_cast<std::uint32_t>(start.response.experiments_done) + (++learned), context);
        scene = record.after;
      } else {
        ROS_WARN("%s: goal %u (%s): a push failed: %s", name().c_str(), g + 1, design.response.object.c_str(),
                 record.reason.c_str());
        if (!getScene(&scene, &why)) break;
      }
      if (context.stopRequested()) break;
    }
    record_goal.request.reached = error < goal_tolerance_;
    record_goal.request.final_error = std::isfinite(error) ? error : 999.0;  // never seen again
    why = callPatiently(nodeHandle(), "knowledge_base/record_goal", record_goal);
    if (!why.empty()) return unstored("goal " + std::to_string(g + 1), why);
    if (record_goal.request.reached) ++result.goals_reached;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      progress_.last = "goal " + std::to_string(g + 1) + ": " + design.response.object + " to (" +
                       literalNumber(design.response.target_x) + ", " + literalNumber(design.response.target_y) + "): " +
                       (record_goal.request.reached ? "reached" : "missed") + ", " + literalNumber(error) + " m off";
    }
    publishProgress(&context);
  }
  finish("finished");
  result.message = "run " + std::to_string(result.run_id) + ": " + std::to_string(result.experiments_done) +
                   " experiments done, " + std::to_string(result.experiments_failed) + " failed, " +
                   std::to_string(result.goals_reached) + " of " + std::to_string(result.goals_tried) + " goals reached";
  return CommandOutcome::succeeded(result.message);
}

}  // namespace xpersif
