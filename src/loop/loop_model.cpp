/**
 * @file loop_model.cpp
 * @brief LOOPMODEL's contracts (the command `run` and the sliding autonomy's operations), its parameters and
 *        configuration, its progress and the gate a run passes at every step (pause, confirm, stop). The run's
 *        steps are in loop_model_run.cpp and loop_model_goals.cpp; one experiment in loop_model_experiment.cpp; the
 *        arena in loop_model_arena.cpp; checkpoints in loop_model_checkpoints.cpp; features and learning in
 *        loop_model_features.cpp; the service calls in service_call.h.
 */
#include "xpersif/loop/loop_model.h"

#include "xpersif/ros/setup_loader.h"

#include <algorithm>
#include <cmath>

#include "xpersif/component/parameter_reader.h"
#include "xpersif/ros/experiment_conversions.h"

namespace xpersif {

LoopModel::LoopModel(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : Supervisor(std::move(nh), std::move(private_nh), "xpersif/LoopModelNodelet") {
  declareRun();
  declareOperations();
}

void LoopModel::declareRun() {
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
}

void LoopModel::declareTrigger(const std::string& name, const std::string& description, const std::string& precondition,
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
}

void LoopModel::declareOperations() {
  declareTrigger("pause", "pause the run after the current step", "running(loop)", "a run must be in progress",
                 "paused(loop)", [this] { return running_ ? "" : "no run is in progress"; },
                 [this] { paused_ = true; });
  declareTrigger("resume", "resume a paused run", "paused(loop)", "the run must be paused", "not paused(loop)",
                 [this] { return paused_ ? "" : "the run is not paused"; }, [this] { paused_ = false; });
  declareTrigger("stop", "stop the run after the current step; it can be resumed later", "running(loop)",
                 "a run must be in progress", "stopped(loop)", [this] { return running_ ? "" : "no run is in progress"; },
                 [this] { stop_requested_ = true; });
  declareTrigger("confirm", "let the waiting experiment go ahead (sliding autonomy)", "waiting(loop)",
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
                            "and goes on (0: never)"),
         core::intParameter("max_same_failures", 3, 0, 100000,
                            "the experimentation phase ends, and the run with it, once this many consecutive "
                            "experiments failed for the same cause (the robot or an object not seen, a stage "
                            "refused with the same code; doc/loop.md); 0: never")});
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
  const int max_same_failures = parameters.get<int>("max_same_failures");
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
    max_same_failures_ = static_cast<std::uint32_t>(max_same_failures);
    progress_.state = "idle";
    if (!progress_pub_) progress_pub_ = pnh.advertise<RunLoopFeedback>("progress", 1, true);
  }
  lockstep_ = std::make_unique<LockstepClient>(nodeHandle(), pnh, pnh.getNamespace(), false);
  model_sub_ = nodeHandle().subscribe<LearnedModel>("machine_learning/model", 1, [this](const LearnedModel::ConstPtr& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    model_run_ = m->run_id;
    model_samples_ = m->samples;
  });
  publishProgress(nullptr);
  Supervisor::onConfigure();
}

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

std::string LoopModel::gate(Run::Context& context, bool confirm_each) {
  auto stopping = [&]() -> std::string {
    if (context.cancelRequested()) return "cancelled";
    if (context.stopRequested()) return "component stopping";
    if (stop_requested_) return "stopped on request";
    return "";
  };
  std::string why = stopping();
  if (!why.empty()) return why;
  for (;;) {
    if (paused_) {
      setState("paused");
      publishProgress(&context);
      while (paused_ && (why = stopping()).empty()) ros::WallDuration(0.02).sleep();
      if (!why.empty()) return why;
    }
    if (!confirm_each) return "";
    const int seen = confirmations_;
    waiting_confirmation_ = true;
    setState("waiting_for_confirmation");
    publishProgress(&context);
    while (confirmations_ == seen && !paused_ && (why = stopping()).empty()) ros::WallDuration(0.02).sleep();
    waiting_confirmation_ = false;
    if (!why.empty()) return why;
    if (confirmations_ != seen) return "";
    // Paused while it waited for a confirmation (the step just before ended sooner than the pause came): it is
    // paused now, and asks again once resumed.
  }
}

}  // namespace xpersif
