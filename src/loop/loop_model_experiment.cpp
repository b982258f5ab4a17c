/**
 * @file loop_model_experiment.cpp
 * @brief One experiment, start to end: the PLANNER plans it from the contracts (observe, push, observe again),
 *        EXECUTION runs the plan, MACHINELEARNING predicts it from the observation before, and the outcome
 *        observed, in the push frame, gives the surprise. Used for the designed experiments and the goal pushes.
 */
#include "xpersif/loop/loop_model.h"

#include <algorithm>
#include <cmath>

#include "xpersif/Predict.h"
#include "xpersif/component/action_wait.h"
#include "xpersif/core/learning/motivation.h"
#include "xpersif/ros/experiment_conversions.h"
#include "loop_text.h"
#include "service_call.h"

namespace xpersif {

using loop::callPatiently;
using loop::callWhenReady;
using loop::literalNumber;

namespace {

/// a - b for yaws folded modulo @p period (a cube's yaw is only known up to quarter turns).
double foldedDifference(double a, double b, double period) {
  double d = std::remainder(a - b, period);
  return d <= -period / 2 ? d + period : d;
}

}  // namespace

void LoopModel::runExperiment(const Experiment& experiment, const std::string& design, Run::Context& context,
                              ExperimentRecord& record, StageFailure* failure) {
  record.design = design;
  record.experiment = experiment;
  record.status = "failed";
  record.started = ros::Time::now().toSec();
  StageFailure ignored;
  StageFailure& failed = failure ? *failure : ignored;
  failed = StageFailure();
  MakePlan plan;
  std::string why = planExperiment(experiment, context, plan, failed);
  if (why.empty()) why = executePlan(plan, context, record, failed);
  if (why.empty()) why = compareWithPrediction(experiment, record, failed);
  if (why.empty()) {
    record.status = "done";
    failed = StageFailure();
  } else {
    record.reason = why;
  }
  record.finished = ros::Time::now().toSec();
}

core::FailureEvidence LoopModel::evidenceOf(const ExperimentRecord& record, const StageFailure& failure,
                                            const FeatureVector& scene) const {
  core::FailureEvidence evidence;
  evidence.failed = record.status != "done";
  evidence.stage = failure.stage;
  evidence.code = failure.code;
  evidence.tried_and_failed = failure.code == ResultCode::FAILED;
  evidence.robot_pose_observed = pose_source_ == "observation";
  // The overhead camera's latest word before the failure: the plan's last observation, else the step's scene.
  const FeatureVector& seen = failure.seen ? *failure.seen : scene;
  evidence.have_vector = !seen.header.stamp.isZero() || !seen.objects.empty() || !seen.missing.empty();
  evidence.robot_found = seen.robot_found;
  evidence.object = record.experiment.object;
  evidence.object_missing =
      std::find(seen.missing.begin(), seen.missing.end(), record.experiment.object) != seen.missing.end();
  return evidence;
}

std::string LoopModel::planExperiment(const Experiment& experiment, Run::Context& context, MakePlan& plan,
                                      StageFailure& failure) {
  plan.request.goal = {"pushed(" + experiment.object + ", " + experiment.side + ", " + literalNumber(experiment.offset) +
                           ", " + literalNumber(experiment.distance) + ")",
                       "observed(scene)"};
  Spending spending(wall_spent_, "plan");
  // Right after start-up the PLANNER may still be reading the components' contracts (contracts_loaded).
  failure.stage = core::ExperimentStage::Plan;
  const std::string why = callWhenReady(
      nodeHandle(), "planner/make_plan", plan, [&] { return context.stopRequested(); }, &failure.code);
  return why.empty() ? "" : "no plan: " + why;
}

std::string LoopModel::executePlan(const MakePlan& plan, Run::Context& context, ExperimentRecord& record,
                                   StageFailure& failure) {
  std::optional<Spending> spending(std::in_place, wall_spent_, "plan");  // connecting to EXECUTION counts as planning
  failure.stage = core::ExperimentStage::Execution;
  failure.code = ResultCode::UNAVAILABLE;
  if (!execution_) {
    execution_ = std::make_unique<actionlib::SimpleActionClient<ExecutePlanAction>>(nodeHandle(), "execution/execute_plan", false);
  }
  auto& execution = *execution_;
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(20.0);
  while (!execution.isServerConnected() && ros::WallTime::now() < until) ros::WallDuration(0.01).sleep();
  if (!execution.isServerConnected()) return "EXECUTION's execute_plan is not offered";
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
      failure.code = ResultCode::FAILED;  // passing: a lost component is restarted, a stop ends the run
      return lost ? "a component was lost during execution" : "stopped during execution";
    }
    ros::WallDuration(0.01).sleep();
  }
  const auto result = execution.getResult();
  failure.code = result ? result->code : static_cast<std::uint8_t>(ResultCode::FAILED);
  if (result && !result->observations.empty()) failure.seen = result->observations.back();
  if (execution.getState() != actionlib::SimpleClientGoalState::SUCCEEDED || !result || !result->success) {
    if (failure.code == ResultCode::OK) failure.code = ResultCode::FAILED;
    return "execution failed: " + execution.getState().getText();
  }
  failure.code = ResultCode::FAILED;  // what follows found the plan's observations wanting
  if (result->observations.size() < 2) return "the plan made fewer than two observations";
  record.before = result->observations.front();
  record.after = result->observations.back();
  const std::string& object = record.experiment.object;
  if (!findObject(record.before, object) || !findObject(record.after, object)) {
    return "the overhead camera lost " + object + " during the experiment";
  }
  return "";
}

std::string LoopModel::compareWithPrediction(const Experiment& experiment, ExperimentRecord& record,
                                             StageFailure& failure) {
  const ObjectFeatures* before = findObject(record.before, experiment.object);
  const ObjectFeatures* after = findObject(record.after, experiment.object);
  // What the model expected (it has not seen this experiment yet) ...
  Spending spending(wall_spent_, "predict");
  Predict predict;
  predict.request.experiment = experiment;
  predict.request.object = *before;
  predict.request.run_id = record.run_id;
  failure = StageFailure();
  failure.stage = core::ExperimentStage::Prediction;
  const std::string why =
      callPatiently(nodeHandle(), "machine_learning/predict", predict, 60.0, false, {}, &failure.code);
  if (!why.empty()) return "no prediction: " + why;
  failure.code = ResultCode::FAILED;  // the outcome cannot be computed
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
    return std::string("cannot compute the outcome: ") + e.what();
  }
  return "";
}

}  // namespace xpersif
