/**
 * @file run_state.h
 * @brief The state one run of LOOPMODEL hands from step to step (loop_model_run.cpp, loop_model_goals.cpp): the
 *        goal and its context, the result being filled, what the knowledge base had of the run, the counts, the
 *        features learned from and the world states the steps start from. Only the run's thread uses it.
 */
#pragma once

#include <cmath>
#include <optional>
#include <string>

#include "xpersif/DesignGoal.h"
#include "xpersif/RecordGoal.h"
#include "xpersif/StartRun.h"
#include "xpersif/loop/loop_model.h"

namespace xpersif {

/// The experiment a step does: hand-chosen (queued by set_next_experiment or the goal's plan) or designed.
struct LoopModel::NextExperiment {
  Experiment experiment;
  std::string design;  ///< the goal's design, or "hand"
};

struct LoopModel::RunState {
  RunState(Run::Context& context, RunLoopResult& result) : goal(context.goal()), context(context), result(result) {}

  const RunLoopGoal& goal;
  Run::Context& context;
  RunLoopResult& result;
  ros::WallTime started;       ///< when the run began (where its wall time went is logged at its end)
  StartRunResponse start;      ///< what the knowledge base had of the run when it started or resumed it
  std::uint32_t done = 0;      ///< experiments designed (done or failed), counted towards goal.experiments
  std::uint32_t learned = 0;   ///< successful experiments the model has seen in this run
  FeatureStage features;       ///< which features the run learns from (FEATURESELECTION's choice once it is due)
  core::FailureStreak streak;  ///< consecutive experiments failing for one cause (~max_same_failures)
  std::string step_state;      ///< the world state at the start of the current step
  std::string next_state;      ///< the world at the end of the last step, stored already as the next one's start
  /// The experiment of a step being done again (a component was lost during it): the one chosen before, unless it
  /// was designed after a loss (LoopModel::redoExperiment), when the scene it read may have been another world.
  std::optional<NextExperiment> again;
};

/// One goal of the goal-directed phase, from GOALDESIGN's choice to the goal stored.
struct LoopModel::GoalAttempt {
  /// What follows a push: the next one, the same one again (a component was lost), or the goal ends here.
  enum class Then { NextPush, SamePushAgain, GoalOver };

  std::uint32_t number = 0;    ///< 1-based, as the log and the progress name it
  std::uint64_t index = 0;     ///< goal.experiments + its 0-based number: its step, numbered after the experiments
  FeatureVector scene;         ///< the scene as the last push left it
  DesignGoalResponse design;   ///< the object and its target
  RecordGoal record;           ///< what is stored of the goal
  double error = INFINITY;     ///< the object's distance from the target, when last seen
  std::string next_push_state; ///< the world the next push starts from, when it is in memory
  Then then = Then::NextPush;
};

}  // namespace xpersif
