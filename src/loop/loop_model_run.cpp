/**
 * @file loop_model_run.cpp
 * @brief LOOPMODEL's command `run` as named steps over one RunState (run_state.h): start or resume the run,
 *        the experimentation phase one experiment at a time, the goal-directed phase (loop_model_goals.cpp), and
 *        the run's end. Each step returns the run's outcome when the run ends there, nothing when it goes on.
 */
#include "run_state.h"

#include <nlohmann/json.hpp>

#include <sstream>

#include "xpersif/DesignExperiment.h"
#include "xpersif/FinishRun.h"
#include "xpersif/RecordExperiment.h"
#include "xpersif/core/common/random_stream.h"
#include "xpersif/core/common/validation.h"
#include "xpersif/ros/experiment_conversions.h"
#include "loop_text.h"
#include "service_call.h"

namespace xpersif {

using loop::callPatiently;
using loop::callWhenReady;
using loop::literalNumber;

namespace {

std::string describe(const Experiment& e) {
  std::ostringstream out;
  out << "push " << e.object << " on " << e.side << " by " << e.distance << " m at offset " << e.offset << " m";
  return out.str();
}

/// The run's parameters as the knowledge base stores them (the report reads `experiments` and `goal_tolerance`).
std::string runParameters(const RunLoopGoal& goal, const std::string& pose_source, double goal_tolerance,
                          int max_goal_pushes) {
  nlohmann::ordered_json parameters;
  parameters["experiments"] = goal.experiments;
  parameters["goals"] = goal.goals;
  parameters["design"] = goal.design;
  parameters["seed"] = goal.seed;
  parameters["pose_source"] = pose_source;
  // Written with six significant digits, as the stored parameters always had it (and the report read it); a
  // number (~goal_tolerance is range-checked, never inf or NaN).
  parameters["goal_tolerance"] = nlohmann::ordered_json::parse(literalNumber(goal_tolerance));
  parameters["max_goal_pushes"] = max_goal_pushes;
  if (goal.provenance.empty()) return parameters.dump();
  const auto provenance = nlohmann::ordered_json::parse(goal.provenance, nullptr, /*allow_exceptions=*/false);
  if (provenance.is_discarded()) {
    // SQLite's json_valid, which the knowledge base checks the parameters with, accepts some text this parser
    // does not (lone surrogates, bytes that are not UTF-8): such a provenance goes as it came, for the knowledge
    // base to accept or refuse (INVALID, with its sentence).
    std::string text = parameters.dump();
    text.insert(text.size() - 1, ",\"provenance\":" + goal.provenance);
    return text;
  }
  parameters["provenance"] = provenance;
  return parameters.dump();
}

}  // namespace

CommandOutcome LoopModel::run(Run::Context& context, RunLoopResult& result) {
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
  RunState run(context, result);
  if (Ending end = startOrResume(run)) return *end;
  if (Ending end = experimentPhase(run)) return *end;
  if (Ending end = goalPhase(run)) return *end;
  return finished(run);
}

// ---- start or resume ------------------------------------------------------------------------------------

LoopModel::Ending LoopModel::startOrResume(RunState& run) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& e : run.goal.plan) next_experiments_.push_back(e);
    progress_ = RunLoopFeedback();
  }
  wall_spent_.clear();
  run.started = ros::WallTime::now();
  std::string why = waitForComponents(run);
  if (why.empty()) why = startInKnowledgeBase(run);
  if (!why.empty()) return CommandOutcome::aborted(run.result.message = "cannot start the run: " + why);
  run.result.run_id = run.start.run_id;
  if (arrange_at_start_ && !run.start.resumed) arrangeAndSettle();
  run.done = run.start.experiments_designed;
  run.streak = core::FailureStreak(max_same_failures_);
  setState("experimenting");
  announceStart(run);
  if (run.start.resumed) restoreResumedWorld(run);
  return std::nullopt;
}

void LoopModel::arrangeAndSettle() {
  // A simulator restarted between the arrangement and the first step's checkpoint (its manager died) would give
  // that checkpoint its fresh, unarranged world, and the run other physics than an uninterrupted one: the world's
  // lineage before and after says so, and the scene is arranged again on the new world.
  for (int attempt = 1;; ++attempt) {
    std::string why;
    checkpointWorld(&why);
    const std::string lineage = why.empty() ? world_lineage_ : std::string();
    why = arrangeInitialScene();
    if (!why.empty()) ROS_WARN("%s: could not arrange the scene: %s", name().c_str(), why.c_str());
    lockstep_->sleepFor(ros::Duration(0.5));  // let odometry and the overhead camera see the new scene
    std::string after_why;
    checkpointWorld(&after_why);
    if (lineage.empty() || !after_why.empty() || world_lineage_ == lineage || attempt == 3) return;
    ROS_WARN("%s: the simulator was restarted while the scene was arranged; arranging it again", name().c_str());
  }
}

std::string LoopModel::waitForComponents(RunState& run) {
  // A LOOPMODEL just restarted is sent the run again as soon as it offers `run`, while its components are still
  // starting: the run waits for all of them (each step of a bring-up is bounded by ~startup_timeout), rather than
  // for one service at a time with a patience that a slow restart outlasts.
  Spending spending(wall_spent_, "starting");
  setState("starting");
  publishProgress(&run.context);
  return waitUntilUp(startupTimeout() * static_cast<double>(supervised().size() + 1), [&] {
    return run.context.cancelRequested() || run.context.stopRequested() || stop_requested_;
  });
}

std::string LoopModel::startInKnowledgeBase(RunState& run) {
  StartRun start;
  start.request.name = run.goal.name;
  start.request.seed = run.goal.seed;
  start.request.design = run.goal.design;
  start.request.resume = run.goal.resume;
  // The knowledge base refuses the run (INVALID, with its sentence) if this is not a JSON object.
  start.request.parameters = runParameters(run.goal, pose_source_, goal_tolerance_, max_goal_pushes_);
  const std::string why = callPatiently(nodeHandle(), "knowledge_base/start_run", start);
  run.start = start.response;
  return why;
}

void LoopModel::announceStart(RunState& run) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    progress_.experiment = run.done;
    const auto left = [](std::uint32_t total, std::uint32_t had) { return total > had ? total - had : 0u; };
    progress_.last = (run.start.resumed ? "resumed run " : "started run ") + std::to_string(run.result.run_id) +
                     " (" + run.goal.name + "): " + std::to_string(run.done) + " experiments and " +
                     std::to_string(run.start.goals_done) + " goals done, " +
                     std::to_string(left(run.goal.experiments, run.done)) + " experiments and " +
                     std::to_string(left(run.goal.goals, run.start.goals_done)) + " goals left";
  }
  publishProgress(&run.context);
}

void LoopModel::restoreResumedWorld(RunState& run) {
  // The step's checkpoint is then the state restored (XPERSim's checkpoint of an unchanged world), so that
  // the first step of a resumed run can be done again too.
  const std::uint32_t step =
      run.done < run.goal.experiments ? run.done : run.goal.experiments + run.start.goals_done;
  const std::string why = restoreCheckpoint(run.result.run_id, step);
  if (why.empty()) {
    ROS_INFO("%s: resumed run %lu from the world state of step %u", name().c_str(),
             static_cast<unsigned long>(run.result.run_id), step);
  } else {
    ROS_WARN("%s: resuming run %lu from the world as it is: %s", name().c_str(),
             static_cast<unsigned long>(run.result.run_id), why.c_str());
  }
}

// ---- the experimentation phase ----------------------------------------------------------------------------

LoopModel::Ending LoopModel::experimentPhase(RunState& run) {
  while (run.done < run.goal.experiments) {
    if (Ending end = experimentStep(run)) return end;
  }
  return std::nullopt;
}

LoopModel::Ending LoopModel::experimentStep(RunState& run) {
  if (Ending end = takeStepState(run)) return end;
  const std::string lineage = world_lineage_;
  const std::uint64_t losses_before = losses_;
  const std::string why = gate(run.context, run.goal.confirm_each);
  if (!why.empty()) return ended(run, why);
  if (Ending end = stopIfAComponentFailed(run, "experiment " + std::to_string(run.done + 1))) return end;
  setState("experimenting");
  FeatureVector scene;
  if (Ending end = sceneForStep(run, run.done, scene)) return end;
  NextExperiment next;
  if (Ending end = chooseExperiment(run, scene, next)) return end;
  // A loss noticed before the design was made may mean the scene it read was a restarted simulator's world file.
  const bool designed_before_any_loss = losses_ == losses_before;
  ExperimentRecord record;
  record.run_id = run.result.run_id;  // MACHINELEARNING predicts with this run's model only
  StageFailure failure;
  runExperiment(next.experiment, next.design, run.context, record, &failure);
  if (run.context.stopRequested() && record.status != "done") return ended(run, "stopped during an experiment");
  // The world as the experiment left it is the next step's start: taken now, before anything is stored, so
  // that a simulator that died after the experiment, while nothing moved the world, is noticed too: the world
  // it gives is another one (its lineage), and the experiment is done again.
  std::string end_why, end_state = checkpointWorld(&end_why);
  const bool replaced = !lineage.empty() && end_why.empty() && world_lineage_ != lineage;
  if ((lostDuring(losses_before, record) || replaced) && !run.step_state.empty()) {
    return redoExperiment(run, next, record, replaced, designed_before_any_loss);
  }
  nameFailedComponent(record);
  if (Ending end = storeExperiment(run, record, end_why, end_state)) return end;
  countExperiment(run, next.experiment, record);
  return checkFailureStreak(run, record, failure, scene);
}

LoopModel::Ending LoopModel::checkFailureStreak(RunState& run, const ExperimentRecord& record,
                                                const StageFailure& failure, const FeatureVector& scene) {
  const core::FailureCause cause = core::classifyFailure(evidenceOf(record, failure, scene));
  if (!run.streak.add(cause)) return std::nullopt;
  // The same cause would fail every experiment left: the phase ends here, with that cause as the run's outcome,
  // rather than spending the run's budget (the experiments are stored; `--resume` goes on once it is fixed).
  const std::uint32_t last = run.done, first = last + 1 - run.streak.length();
  ROS_ERROR("%s: experiments %u to %u failed for the same cause; the run stops", name().c_str(), first, last);
  return ended(run, "experiments " + std::to_string(first) + " to " + std::to_string(last) +
                        " failed for the same cause, " + core::describeCause(cause, loop::resultCodeName(cause.code)) +
                        " (the last one: " + record.reason + "); the experimentation phase stops",
               RunLoopResult::REPEATING_CAUSE);
}

LoopModel::Ending LoopModel::takeStepState(RunState& run) {
  if (!run.next_state.empty()) {
    run.step_state = std::move(run.next_state);
    run.next_state.clear();
    return std::nullopt;
  }
  std::string refused;
  run.step_state = takeCheckpoint(run.result.run_id, run.done, &refused);
  if (!refused.empty()) return unstored(run, "the world state of experiment " + std::to_string(run.done + 1), refused);
  return std::nullopt;
}

LoopModel::Ending LoopModel::sceneForStep(RunState& run, std::uint64_t step, FeatureVector& scene) {
  std::string why = ensureFeatures(run.result.run_id, run.goal.seed, run.done, run.goal.experiments, run.features);
  if (!why.empty()) return blind(run, "cannot set the features learned from", why);
  if (!getScene(&scene, &why)) return blind(run, "cannot observe the scene", why);
  if (tidy_ && tidyArena(scene, core::streamSeed(run.goal.seed, run.result.run_id, step, core::StreamPurpose::Tidy)) > 0 &&
      !getScene(&scene, &why)) {
    return ended(run, "cannot observe the scene: " + why);
  }
  return std::nullopt;
}

LoopModel::Ending LoopModel::chooseExperiment(RunState& run, const FeatureVector& scene, NextExperiment& next) {
  if (run.again) {
    next = std::move(*run.again);
    run.again.reset();
    return std::nullopt;
  }
  next.design = run.goal.design;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!next_experiments_.empty()) {
      next.experiment = next_experiments_.front();
      next_experiments_.pop_front();
      next.design = "hand";
      return std::nullopt;
    }
  }
  DesignExperiment request;
  request.request.design = run.goal.design;
  request.request.scored = run.start.experiments_done + run.learned;  // what MOTIVATION must have heard of
  request.request.seeded = true;
  request.request.stream = core::streamSeed(run.goal.seed, run.result.run_id, run.done, core::StreamPurpose::Design);
  request.request.experiment = run.done;
  request.request.run_id = run.result.run_id;
  // The scene, so that DESIGNOFEXPERIMENTS chooses a push that can be done from here.
  appendScenePoses(scene, &request.request.scene_objects, &request.request.scene_poses);
  Spending spending(wall_spent_, "design");
  const std::string why = callWhenReady(nodeHandle(), "design_of_experiments/design_experiment", request,
                                        [&] { return run.context.stopRequested(); });
  if (!why.empty()) return ended(run, "DESIGNOFEXPERIMENTS failed: " + why);
  next.experiment = request.response.experiment;
  return std::nullopt;
}

LoopModel::Ending LoopModel::redoExperiment(RunState& run, const NextExperiment& next, const ExperimentRecord& record,
                                            bool replaced, bool designed_before_any_loss) {
  // What the experiment did is not what an uninterrupted run would have done. It is not stored; once every
  // component is back, the world goes back to the step's state and the same experiment is done again.
  ROS_WARN("%s: a component was lost during experiment %u (%s%s); doing it again from the world as it was",
           name().c_str(), run.done + 1, record.status == "done" ? "it finished" : record.reason.c_str(),
           replaced ? "; the simulator's world is another one now" : "");
  const std::string why = returnTo(run.context, run.result.run_id, run.step_state);
  if (!why.empty()) return ended(run, "cannot do experiment " + std::to_string(run.done + 1) + " again: " + why);
  // A design made after a loss may have read the restarted simulator's world file (doc/lockstep.md): it is made
  // again from the restored world, whose frames come once the clock has passed the restore (restoreCheckpoint).
  // A queued hand experiment stays.
  if (designed_before_any_loss || next.design == "hand") {
    run.again = next;
  } else {
    ROS_WARN("%s: experiment %u was designed after a component was lost; it is designed again from the world as it "
             "was", name().c_str(), run.done + 1);
  }
  return std::nullopt;
}

LoopModel::Ending LoopModel::storeExperiment(RunState& run, const ExperimentRecord& record, const std::string& end_why,
                                             const std::string& end_state) {
  const std::uint64_t run_id = run.result.run_id;
  std::string why;
  if (end_why.empty()) {  // the next step's state first: stored before the experiment, a resume never lacks it
    why = storeWorldState(run_id, run.done + 1, end_state);
    if (!why.empty()) {
      if (!run.step_state.empty()) restoreCheckpoint(run_id, run.done, run.step_state);
      return unstored(run, "the world state after experiment " + std::to_string(run.done + 1), why);
    }
  }
  {
    Spending spending(wall_spent_, "record");
    why = storeRecord(run_id, record);
  }
  if (!why.empty()) {
    // The world goes back to where the knowledge base has it: before this experiment.
    if (!run.step_state.empty()) restoreCheckpoint(run_id, run.done, run.step_state);
    return unstored(run, "experiment " + std::to_string(run.done + 1), why);
  }
  if (end_why.empty()) run.next_state = end_state;
  return std::nullopt;
}

std::string LoopModel::storeRecord(std::uint64_t run_id, const ExperimentRecord& record) {
  RecordExperiment store;
  store.request.record = record;
  store.request.record.run_id = run_id;
  // The knowledge base refuses a longer reason, and a refused record would end the run naming the refusal, not the
  // failure: it keeps the reason's beginning (the cause) and end; the log has the whole.
  store.request.record.reason = core::shortenText(record.reason, core::KnowledgeBase::kMaxTextLength);
  return callPatiently(nodeHandle(), "knowledge_base/record_experiment", store);
}

void LoopModel::countExperiment(RunState& run, const Experiment& experiment, const ExperimentRecord& record) {
  ++run.done;
  if (record.status == "done") {
    ++run.result.experiments_done;
    waitForLearning(run.result.run_id, learnedOneMore(run), run.context);
  } else {
    ++run.result.experiments_failed;
    ROS_WARN("%s: experiment %u failed: %s", name().c_str(), run.done, record.reason.c_str());
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    progress_.experiment = run.done;
    progress_.surprise = record.surprise;
    progress_.last = describe(experiment) + (record.status == "done" ? "" : " (failed: " + record.reason + ")");
  }
  publishProgress(&run.context);
}

std::uint32_t LoopModel::learnedOneMore(RunState& run) {
  return static_cast<std::uint32_t>(run.start.experiments_done) + (++run.learned);
}

// ---- the run's end --------------------------------------------------------------------------------------

void LoopModel::finish(RunState& run, const std::string& status) {
  std::ostringstream spent;
  double counted = 0;
  for (const auto& [step, seconds] : wall_spent_) {
    spent << (counted == 0 ? "" : ", ") << step << " " << core::describeNumber(seconds);
    counted += seconds;
  }
  ROS_INFO("%s: run %lu %s after %.1f s of wall time: %s, other %.1f s", name().c_str(),
           static_cast<unsigned long>(run.result.run_id), status.c_str(), (ros::WallTime::now() - run.started).toSec(),
           spent.str().c_str(), (ros::WallTime::now() - run.started).toSec() - counted);
  FinishRun finish_run;
  finish_run.request.run_id = run.result.run_id;
  finish_run.request.status = status;
  callPatiently(nodeHandle(), "knowledge_base/finish_run", finish_run);
  setState(status);
  publishProgress(&run.context);
}

CommandOutcome LoopModel::ended(RunState& run, const std::string& reason, std::uint8_t code) {
  finish(run, "stopped");
  run.result.code = code;
  run.result.message = reason + " after " + std::to_string(run.result.experiments_done) + " experiments";
  if (run.context.cancelRequested()) return CommandOutcome::preempted(run.result.message);
  return CommandOutcome::aborted(run.result.message);
}

CommandOutcome LoopModel::blind(RunState& run, const std::string& what, const std::string& why) {
  // VISION works from OBSERVATION's vectors: a perceiving component that refuses to work is the cause to name,
  // not the wait downstream of it, and it fails every experiment until the set-up changes.
  const std::string refusal = perceptionRefusal();
  if (refusal.empty()) return ended(run, what + ": " + why);
  return ended(run, what + ": " + refusal + " (" + why + ")", RunLoopResult::REPEATING_CAUSE);
}

LoopModel::Ending LoopModel::stopIfAComponentFailed(RunState& run, const std::string& step) {
  // A failed component stays in ERROR until it is configured again: each step would fail downstream of it, with a
  // sentence about the command it refused ("MANIPULATION is INACTIVE") rather than about why (ROBOTMODEL's failure).
  const std::string failed = failedComponent();
  if (failed.empty()) return std::nullopt;
  ROS_ERROR("%s: %s; the run stops before %s", name().c_str(), failed.c_str(), step.c_str());
  return ended(run, failed + " (`--resume` goes on once it is configured again); the run stops before " + step + ",",
               RunLoopResult::REPEATING_CAUSE);
}

CommandOutcome LoopModel::unstored(RunState& run, const std::string& what, const std::string& why) {
  // Nothing of the step is done, and the world is as the knowledge base says.
  return ended(run, "the knowledge base did not store " + what + " (" + why + "); the run stops before it, and " +
                        "`--resume` goes on from there once the knowledge base can store again");
}

CommandOutcome LoopModel::finished(RunState& run) {
  finish(run, "finished");
  const RunLoopResult& result = run.result;
  run.result.message = "run " + std::to_string(result.run_id) + ": " + std::to_string(result.experiments_done) +
                       " experiments done, " + std::to_string(result.experiments_failed) + " failed, " +
                       std::to_string(result.goals_reached) + " of " + std::to_string(result.goals_tried) +
                       " goals reached";
  return CommandOutcome::succeeded(run.result.message);
}

}  // namespace xpersif
