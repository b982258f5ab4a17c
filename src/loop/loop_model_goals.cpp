/**
 * @file loop_model_goals.cpp
 * @brief LOOPMODEL's goal-directed phase, as named steps over the run's RunState (run_state.h): GOALDESIGN sets a
 *        goal ("bring the red cube to (x, y)") and chooses pushes with the learned model until the object is close
 *        enough or the goal has had its pushes; each push is planned, executed and stored as an experiment is.
 */
#include "run_state.h"

#include "xpersif/ChoosePush.h"
#include "xpersif/core/common/random_stream.h"
#include "xpersif/ros/experiment_conversions.h"
#include "loop_text.h"
#include "service_call.h"

namespace xpersif {

using loop::call;
using loop::callPatiently;
using loop::literalNumber;

LoopModel::Ending LoopModel::goalPhase(RunState& run) {
  if (run.goal.goals > 0) {
    setState("goal_directed");
    publishProgress(&run.context);
  }
  for (std::uint32_t g = run.start.goals_done; g < run.goal.goals; ++g) {
    if (Ending end = goalStep(run, g)) return end;
  }
  return std::nullopt;
}

LoopModel::Ending LoopModel::goalStep(RunState& run, std::uint32_t g) {
  GoalAttempt attempt;
  attempt.number = g + 1;
  // Goal g's choices are numbered after the experiments, so that they never share a stream with them.
  attempt.index = run.goal.experiments + g;
  if (Ending end = checkpointGoal(run, attempt)) return end;
  const std::string why = gate(run.context, run.goal.confirm_each);  // sliding autonomy holds in both phases
  if (!why.empty()) return ended(run, why);
  if (Ending end = stopIfAComponentFailed(run, "goal " + std::to_string(attempt.number))) return end;
  // The choice of a run of no more than ~select_features_after experiments is made here; again after a loss.
  if (Ending end = sceneForStep(run, attempt.index, attempt.scene)) return end;
  if (Ending end = designGoal(run, attempt)) return end;
  if (Ending end = pursueGoal(run, attempt)) return end;
  return recordGoal(run, attempt);
}

LoopModel::Ending LoopModel::checkpointGoal(RunState& run, const GoalAttempt& attempt) {
  std::string refused;
  const std::string lineage_before = world_lineage_;
  takeCheckpoint(run.result.run_id, static_cast<std::uint32_t>(attempt.index), &refused);
  if (!refused.empty()) return unstored(run, "the world state of goal " + std::to_string(attempt.number), refused);
  if (!lineage_before.empty() && world_lineage_ != lineage_before) {
    ROS_WARN("%s: the simulator was replaced since the last step ended; goal %u starts from the world it has now "
             "(a known gap: the world the last step left is lost)", name().c_str(), attempt.number);
  }
  return std::nullopt;
}

LoopModel::Ending LoopModel::designGoal(RunState& run, GoalAttempt& attempt) {
  DesignGoal design;
  design.request.scene = attempt.scene;
  design.request.samples = modelSamples();
  design.request.features = learningFeatures();
  design.request.seeded = true;
  design.request.stream = core::streamSeed(run.goal.seed, run.result.run_id, attempt.index, core::StreamPurpose::Goal);
  design.request.tolerance = goal_tolerance_;
  std::string why;
  {
    Spending spending(wall_spent_, "design");
    why = call(nodeHandle(), "goal_design/design_goal", design);
  }
  if (!why.empty()) return ended(run, "GOALDESIGN could not set a goal: " + why);
  ROS_INFO("%s: goal %u: %s", name().c_str(), attempt.number, design.response.message.c_str());
  ++run.result.goals_tried;
  attempt.design = design.response;
  attempt.record.request.run_id = run.result.run_id;
  attempt.record.request.object = design.response.object;
  attempt.record.request.target_x = design.response.target_x;
  attempt.record.request.target_y = design.response.target_y;
  return std::nullopt;
}

LoopModel::Ending LoopModel::pursueGoal(RunState& run, GoalAttempt& attempt) {
  const DesignGoalResponse& target = attempt.design;
  for (int push = 0; push <= max_goal_pushes_; ++push) {
    const ObjectFeatures* object = findObject(attempt.scene, target.object);
    if (!object) break;
    attempt.error = std::hypot(object->position.x - target.target_x, object->position.y - target.target_y);
    if (attempt.error < goal_tolerance_ || push == max_goal_pushes_) break;
    if (Ending end = pushOnce(run, attempt, push)) return end;
    if (attempt.then == GoalAttempt::Then::GoalOver) break;
    if (attempt.then == GoalAttempt::Then::SamePushAgain) --push;
  }
  return std::nullopt;
}

LoopModel::Ending LoopModel::pushOnce(RunState& run, GoalAttempt& attempt, int push) {
  attempt.then = GoalAttempt::Then::NextPush;
  // A component failed during the goal would fail each push left of it (ended, the goal is done again on --resume).
  if (Ending end = stopIfAComponentFailed(run, "push " + std::to_string(push + 1) + " of goal " +
                                                   std::to_string(attempt.number))) {
    return end;
  }
  // Each push starts from a checkpoint kept in memory, so that a push during which a component was lost is done
  // again: its own when it is done again, or the one the last push left; else a new checkpoint.
  std::string push_state = std::move(attempt.next_push_state);
  attempt.next_push_state.clear();
  if (push_state.empty()) {
    std::string ignored;
    push_state = checkpointWorld(&ignored);
  }
  const std::string push_lineage = world_lineage_;
  std::string why = ensureFeatures(run.result.run_id, run.goal.seed, run.done, run.goal.experiments,
                                   run.features);  // again after a loss
  if (!why.empty()) return ended(run, "cannot set the features learned from: " + why);
  const std::optional<Experiment> chosen = choosePush(run, attempt, push);
  if (!chosen) {  // the goal ends here, missed; the run goes on with the next goal
    attempt.then = GoalAttempt::Then::GoalOver;
    return std::nullopt;
  }
  ExperimentRecord record;
  record.run_id = run.result.run_id;  // MACHINELEARNING predicts with this run's model only
  const std::uint64_t losses_before = losses_;
  runExperiment(*chosen, "goal", run.context, record);
  // As after an experiment: the world the push left, taken before anything is stored, from the same simulator.
  std::string end_why, end_state = checkpointWorld(&end_why);
  const bool replaced = !push_lineage.empty() && end_why.empty() && world_lineage_ != push_lineage;
  if ((lostDuring(losses_before, record) || replaced) && !push_state.empty() && !run.context.stopRequested()) {
    ROS_WARN("%s: a component was lost during push %d of goal %u; doing it again from the world as it was",
             name().c_str(), push + 1, attempt.number);
    why = returnTo(run.context, run.result.run_id, push_state);
    if (!why.empty()) {
      return ended(run, "cannot do push " + std::to_string(push + 1) + " of goal " + std::to_string(attempt.number) +
                            " again: " + why);
    }
    attempt.next_push_state = push_state;
    attempt.then = GoalAttempt::Then::SamePushAgain;
    return std::nullopt;
  }
  ++attempt.record.request.pushes;
  // Every goal push is stored, a failed one with its reason, as the designed experiments are.
  nameFailedComponent(record);
  why = storeRecord(run.result.run_id, record);
  if (!why.empty()) {
    if (!push_state.empty()) restoreCheckpoint(run.result.run_id, 0, push_state);
    return unstored(run, "push " + std::to_string(push + 1) + " of goal " + std::to_string(attempt.number), why);
  }
  if (end_why.empty()) attempt.next_push_state = end_state;  // the next push starts from the world this one left
  afterPush(run, attempt, record);
  return std::nullopt;
}

std::optional<Experiment> LoopModel::choosePush(RunState& run, const GoalAttempt& attempt, int push) {
  ChoosePush choose;
  choose.request.samples = modelSamples();
  choose.request.features = learningFeatures();
  choose.request.scene = attempt.scene;
  choose.request.object = attempt.design.object;
  choose.request.target_x = attempt.design.target_x;
  choose.request.target_y = attempt.design.target_y;
  choose.request.seeded = true;
  choose.request.stream = core::streamSeed(run.goal.seed, run.result.run_id, attempt.index * 1000 + push,
                                           core::StreamPurpose::GoalPush);
  std::string why;
  {
    Spending spending(wall_spent_, "design");
    why = call(nodeHandle(), "goal_design/choose_push", choose);
  }
  if (!why.empty()) {
    ROS_WARN("%s: goal %u (%s): GOALDESIGN chose no push: %s", name().c_str(), attempt.number,
             attempt.design.object.c_str(), why.c_str());
    return std::nullopt;
  }
  return choose.response.experiment;
}

void LoopModel::afterPush(RunState& run, GoalAttempt& attempt, const ExperimentRecord& record) {
  if (record.status == "done") {
    waitForLearning(run.result.run_id, learnedOneMore(run), run.context);
    attempt.scene = record.after;
  } else {
    ROS_WARN("%s: goal %u (%s): a push failed: %s", name().c_str(), attempt.number, attempt.design.object.c_str(),
             record.reason.c_str());
    std::string why;
    if (!getScene(&attempt.scene, &why)) {
      attempt.then = GoalAttempt::Then::GoalOver;
      return;
    }
  }
  if (run.context.stopRequested()) attempt.then = GoalAttempt::Then::GoalOver;
}

LoopModel::Ending LoopModel::recordGoal(RunState& run, GoalAttempt& attempt) {
  RecordGoal& record = attempt.record;
  record.request.reached = attempt.error < goal_tolerance_;
  record.request.final_error = std::isfinite(attempt.error) ? attempt.error : 999.0;  // never seen again
  const std::string why = callPatiently(nodeHandle(), "knowledge_base/record_goal", record);
  if (!why.empty()) return unstored(run, "goal " + std::to_string(attempt.number), why);
  if (record.request.reached) ++run.result.goals_reached;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    progress_.last = "goal " + std::to_string(attempt.number) + ": " + attempt.design.object + " to (" +
                     literalNumber(attempt.design.target_x) + ", " + literalNumber(attempt.design.target_y) + "): " +
                     (record.request.reached ? "reached" : "missed") + ", " + literalNumber(attempt.error) + " m off";
  }
  publishProgress(&run.context);
  return std::nullopt;
}

}  // namespace xpersif
